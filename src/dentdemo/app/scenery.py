"""What is drawn of the bodies and never simulated: a plate's sides, a mesh file's own image on the
GPU, the coarser render meshes of curved bodies. The Simulation (the world: bodies, physics, the
carve queue and each body's mesh and maps, which the carve needs) knows nothing of these;
`Scenery.sync` follows its bodies each frame, making parts for new ones, keeping them across a
reset while the body's shape is the same, and releasing the parts of bodies that are gone."""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np
from numpy.typing import NDArray

from dentdemo.app.shared import Shared
from dentdemo.app.simulation import SimBody, Simulation
from dentdemo.gl.context import GLContext
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.mesh.shapes import coarser_levels, plate_sides
from dentdemo.model.shapes import Plate, Shape
from dentdemo.render.frame import MeshLevel


@dataclass
class DrawnParts:
    """The parts of one body only the renderer uses; made for a body of `shape`."""

    shape: Shape
    #: A plate's thickness below its dentable top face: drawn, never carved.
    under: GpuMesh | None = None
    #: The mesh file's own base-colour image on the GPU, if it brought one.
    texture: moderngl.Texture | None = None
    #: Coarser render meshes of a curved body (render/frame.py MeshLevel), finest first.
    coarser: tuple[MeshLevel, ...] = ()

    def release(self) -> None:
        if self.under is not None:
            self.under.release()
        if self.texture is not None:
            self.texture.release()
        for level in self.coarser:
            level.mesh.release()


class Scenery:
    """The drawn parts of a Simulation's bodies, by body id; bodies of one shape share theirs
    (a plate's sides, the coarser meshes of balls of one radius: made once)."""

    def __init__(self, gl: GLContext) -> None:
        self.gl = gl
        self.parts: dict[str, DrawnParts] = {}
        self._shared: Shared[Shape, DrawnParts] = Shared(self._make, DrawnParts.release)

    def sync(self, sim: Simulation) -> dict[str, DrawnParts]:
        """Parts for every body of `sim` now (made where missing or made for another shape),
        none for bodies that are gone."""
        for body_id in [i for i in self.parts if i not in sim.bodies]:
            self._shared.give_back(self.parts.pop(body_id).shape)
        for body_id, body in sim.bodies.items():
            parts = self.parts.get(body_id)
            if parts is None or parts.shape != body.spec.shape:
                if parts is not None:
                    self._shared.give_back(parts.shape)
                self.parts[body_id] = self._shared.take(body.spec.shape, body)
        return self.parts

    def _make(self, shape: Shape, body: SimBody) -> DrawnParts:
        under = GpuMesh(self.gl, plate_sides(shape)) if isinstance(shape, Plate) else None
        image = body.mesh.base_colour_image  # the shape's mesh: every body of it has this one
        texture = _upload_image(self.gl, image) if image is not None else None
        coarser = tuple(
            MeshLevel(GpuMesh(self.gl, level.mesh), level.error) for level in coarser_levels(shape)
        )
        return DrawnParts(shape, under, texture, coarser)

    def release(self) -> None:
        self._shared.release()
        self.parts.clear()


def _upload_image(gl: GLContext, image: NDArray[np.uint8]) -> moderngl.Texture:
    """An sRGB RGBA8 image (rows top-down) as a repeating, mipmapped texture whose row 0 is the
    image's bottom row (texture v = 0, as OBJ and glTF coordinates count it after the flip)."""
    rgba = np.ascontiguousarray(image[::-1], dtype=np.uint8)
    texture = gl.ctx.texture((rgba.shape[1], rgba.shape[0]), 4, rgba.tobytes())
    texture.build_mipmaps()
    texture.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    texture.repeat_x = texture.repeat_y = True
    return texture
