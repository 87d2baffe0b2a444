"""The mesh of each shape kind (body-local metres), at a tessellation the caller picks."""

from __future__ import annotations

from dataclasses import dataclass

from dentdemo.mesh import primitives
from dentdemo.mesh.mesh import Mesh
from dentdemo.model.shapes import Box, Capsule, Cylinder, MeshFile, Plane, Plate, Shape, Sphere

#: Side of the stand-in plate that plays the ground plane when a carve needs a mesh for it, m.
GROUND_PROXY_SIDE = 4.0


@dataclass(frozen=True)
class Tessellation:
    """How finely curved primitives are cut: cube-sphere cells per face edge, segments around a
    capsule or cylinder, rings along a capsule's caps."""

    sphere: int = 12
    around: int = 64
    rings: int = 16

    @staticmethod
    def press(detail: int) -> Tessellation:
        """The press tool's (indent, bench, carve tests): finer with `detail`."""
        return Tessellation(sphere=24 * detail, around=48 * detail, rings=12 * detail)


#: The sandbox's bodies.
SANDBOX = Tessellation()


def shape_mesh(shape: Shape, tessellation: Tessellation = SANDBOX) -> Mesh:
    """The render and carve mesh of a shape; a mesh file is loaded (once, see mesh.loader)."""
    t = tessellation
    match shape:
        case Sphere(radius=r):
            return primitives.sphere(r, subdivisions=t.sphere)
        case Box(size=size):
            return primitives.box(size)
        case Plate(side=side):
            return primitives.plate(side)
        case Capsule(radius=r, length=length):
            return primitives.capsule(r, length, around=t.around, rings=t.rings)
        case Cylinder(radius=r, length=length):
            return primitives.cylinder(r, length, around=t.around)
        case MeshFile(path=path, scale=scale):
            from dentdemo.mesh.loader import load_mesh

            return load_mesh(path, scale)
        case Plane():
            return primitives.plate(GROUND_PROXY_SIDE)
    raise TypeError(f"not a shape: {shape!r}")
