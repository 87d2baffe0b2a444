"""A scene's physics world: every body of the scene, mesh shapes with their triangles."""

from __future__ import annotations

from typing import TYPE_CHECKING

from dentdemo.errors import DentdemoError
from dentdemo.model.scene import Scene

if TYPE_CHECKING:  # ODE loads on first use, so commands without physics run without libode
    from dentdemo.physics.world import PhysicsWorld


def build_world(scene: Scene) -> PhysicsWorld:
    """A PhysicsWorld with every body of the scene; mesh shapes load their triangles."""
    from dentdemo.physics.world import PhysicsWorld

    world = PhysicsWorld(scene.physics)
    for body in scene.bodies:
        arrays = None
        if body.shape.kind == "mesh":
            from dentdemo.mesh.loader import load_mesh

            mesh = load_mesh(body.shape.mesh_path, body.shape.scale)
            arrays = (mesh.positions, mesh.indices)
        try:
            world.add_body(body, arrays)
        except ValueError as exc:
            raise DentdemoError(f"{scene.source}: [body.{body.id}]: {exc}") from None
    return world
