"""A scene's physics world: every body of the scene, mesh shapes with their triangles."""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

from dentdemo.errors import DentdemoError
from dentdemo.model.scene import Scene
from dentdemo.model.shapes import MeshFile

if TYPE_CHECKING:  # ODE loads on first use, so commands without physics run without libode
    from dentdemo.physics.world import PhysicsWorld


def build_world(scene: Scene) -> PhysicsWorld:
    """A PhysicsWorld with every body of the scene; mesh shapes load their triangles."""
    from dentdemo.physics.world import PhysicsWorld

    world = PhysicsWorld(scene.physics)
    try:
        for body in scene.bodies:
            # A body's warnings (a mesh re-atlassed) are shown once the body is accepted: a
            # rejected one gets its error line alone.
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                arrays = None
                if isinstance(body.shape, MeshFile):
                    from dentdemo.mesh.loader import load_mesh

                    mesh = load_mesh(body.shape.path, body.shape.scale)
                    arrays = (mesh.positions, mesh.indices)
                try:
                    world.add_body(body, arrays)
                except ValueError as exc:
                    raise DentdemoError(f"{scene.source}: [body.{body.id}]: {exc}") from None
            for warning in caught:
                warnings.warn(str(warning.message), warning.category, stacklevel=2)
    except BaseException:
        world.close()
        raise
    return world
