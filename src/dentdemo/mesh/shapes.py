"""The mesh of each shape kind (body-local metres), at a tessellation the caller picks."""

from __future__ import annotations

import math
from dataclasses import dataclass

from dentdemo.errors import ArgumentError
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

    def coarser(self, divisor: int) -> Tessellation:
        """Every count divided by `divisor`: the same vertex grid with every divisor-th line
        kept, so each vertex keeps its position and texture address."""
        return Tessellation(self.sphere // divisor, self.around // divisor, self.rings // divisor)


#: The sandbox's bodies.
SANDBOX = Tessellation()
#: The render levels of detail of a curved body: SANDBOX divided by these.
LEVEL_DIVISORS = (2, 4)


@dataclass(frozen=True)
class Level:
    """A coarser render mesh of a shape and how far it strays from the true surface."""

    mesh: Mesh
    #: Largest distance between its flat triangles and the shape's surface, metres.
    error: float


def coarser_levels(shape: Shape, tessellation: Tessellation = SANDBOX) -> list[Level]:
    """Render-only meshes of a curved shape at coarser tessellations (coarsest last). They keep
    the full mesh's texture addresses at every vertex they keep, so they show the same maps;
    none for flat shapes and loaded meshes."""
    if not isinstance(shape, Sphere | Capsule | Cylinder):
        return []
    levels = []
    for divisor in LEVEL_DIVISORS:
        coarse = tessellation.coarser(divisor)
        levels.append(Level(shape_mesh(shape, coarse), chord_error(shape, coarse)))
    return levels


def chord_error(shape: Shape, tessellation: Tessellation) -> float:
    """The largest distance, metres, between the triangles of `shape_mesh(shape, tessellation)`
    and the true surface: the sagitta r (1 - cos rho) at the angular circumradius rho of the
    widest triangle. 0 for flat shapes and for loaded meshes (they are their own surface)."""
    t = tessellation
    match shape:
        case Sphere(radius=r):
            # Equal-angle cube cells span at most pi/2 / n of arc a side; near the cube's
            # corners they are rhombi of up to 120 degrees, whose long diagonal (a triangle's
            # longest edge, the farthest from the sphere) spans up to sqrt(3) sides.
            side = math.pi / (2 * t.sphere)
            return _sagitta(r, side * math.sqrt(3) / 2)
        case Capsule(radius=r):
            around, along = 2 * math.pi / t.around, math.pi / (2 * t.rings)
            return _sagitta(r, math.hypot(around, along) / 2)
        case Cylinder(radius=r):
            return _sagitta(r, math.pi / t.around)
    return 0.0


def _sagitta(radius: float, half_angle: float) -> float:
    return radius * (1.0 - math.cos(half_angle))


def shape_mesh(shape: Shape, tessellation: Tessellation = SANDBOX) -> Mesh:
    """The render and carve mesh of a shape; a mesh file is loaded (once, see mesh.loader)."""
    t = tessellation
    match shape:
        case Sphere(radius=r):
            return primitives.sphere(r, subdivisions=t.sphere)
        case Box(size=size):
            return primitives.box(size)
        case Plate(side=side, thickness=thickness):
            return primitives.plate(side, thickness=thickness)
        case Capsule(radius=r, length=length):
            return primitives.capsule(r, length, around=t.around, rings=t.rings)
        case Cylinder(radius=r, length=length):
            return primitives.cylinder(r, length, around=t.around)
        case MeshFile(path=path, scale=scale):
            from dentdemo.mesh.loader import load_mesh

            return load_mesh(path, scale)
        case Plane():
            return primitives.plate(GROUND_PROXY_SIDE)
    raise ArgumentError(
        f"shape must be a Sphere, Box, Capsule, Cylinder or Plate, got {type(shape).__name__} "
        f"{shape!r}"
    )


def plate_sides(plate: Plate) -> Mesh:
    """A plate's body below its top face (body space: the top face is y = 0), metres: its sides
    and bottom up to the top face, without a lid (a displaced dent in the top face shows);
    drawn and exported, never dented."""
    t = plate.thickness
    sides = primitives.box((plate.side, t, plate.side))
    sides.positions[:, 1] -= t / 2
    sides.indices = sides.indices[sides.normals[sides.indices[:, 0], 1] < 0.5]
    return sides
