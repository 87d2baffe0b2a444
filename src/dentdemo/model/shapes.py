"""The shape vocabulary: one frozen type per kind, shared by scene files, the physics (geoms and
masses, physics/world.py), the meshes (mesh/shapes.py) and the press tool. Sizes in metres, in the
body's local frame (+Y up; capsules and cylinders lie along local Z). Pure data and geometry."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class Sphere:
    radius: float

    def volume(self) -> float:
        return 4.0 / 3.0 * math.pi * self.radius**3

    def bounding_radius(self) -> float:
        return self.radius


@dataclass(frozen=True)
class Box:
    #: Full extents along local x, y, z.
    size: tuple[float, float, float]

    def volume(self) -> float:
        return float(np.prod(self.size))

    def bounding_radius(self) -> float:
        return float(np.linalg.norm(self.size) / 2)


@dataclass(frozen=True)
class Capsule:
    """A cylinder of `length` along local Z with hemispherical caps of `radius`."""

    radius: float
    length: float

    def volume(self) -> float:
        r = self.radius
        return math.pi * r * r * self.length + 4.0 / 3.0 * math.pi * r**3

    def bounding_radius(self) -> float:
        return self.length / 2 + self.radius


@dataclass(frozen=True)
class Cylinder:
    """Along local Z, flat ends."""

    radius: float
    length: float

    def volume(self) -> float:
        return math.pi * self.radius**2 * self.length

    def bounding_radius(self) -> float:
        return math.hypot(self.length / 2, self.radius)


@dataclass(frozen=True)
class Plate:
    """A side x thickness x side box whose top face (local y = 0) carries the dentable map."""

    side: float
    thickness: float = 0.02

    def volume(self) -> float:
        return self.side * self.side * self.thickness

    def bounding_radius(self) -> float:
        return math.hypot(self.side / math.sqrt(2), self.thickness)


@dataclass(frozen=True)
class Plane:
    """The static ground y = 0: infinite, never dented."""

    def volume(self) -> float:
        return 0.0

    def bounding_radius(self) -> float:
        return math.inf


@dataclass(frozen=True)
class MeshFile:
    """A triangle mesh file (anything trimesh reads), scaled; its volume comes from the mesh."""

    path: str
    scale: float = 1.0

    def volume(self) -> float:
        return 0.0

    def bounding_radius(self) -> float:
        return math.inf


Shape = Sphere | Box | Capsule | Cylinder | Plate | Plane | MeshFile
#: Names in scene files and on the command line.
KINDS: dict[str, type[Shape]] = {
    "sphere": Sphere,
    "box": Box,
    "capsule": Capsule,
    "cylinder": Cylinder,
    "plane": Plane,
    "plate": Plate,
    "mesh": MeshFile,
}


def kind_of(shape: Shape) -> str:
    """The name of a shape's kind (scene files, summaries)."""
    return next(name for name, cls in KINDS.items() if isinstance(shape, cls))


def as_dict(shape: Shape) -> dict[str, Any]:
    """{"kind": name, field: value, ...}, JSON-ready."""
    fields = {f.name: getattr(shape, f.name) for f in dataclasses.fields(shape)}
    return {
        "kind": kind_of(shape),
        **{k: list(v) if isinstance(v, tuple) else v for k, v in fields.items()},
    }


def from_dict(data: dict[str, Any]) -> Shape:
    """The inverse of `as_dict` (KeyError or TypeError on a bad one)."""
    fields = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items() if k != "kind"}
    kind: Any = KINDS[data["kind"]]  # each kind checks its own fields
    return cast(Shape, kind(**fields))


def support(shape: Shape, direction: NDArray[np.float64]) -> NDArray[np.float64]:
    """The farthest point of a built-in solid along `direction` (local metres; where a face is
    farthest, its centre)."""
    n = np.asarray(direction, dtype=np.float64)
    n = n / max(float(np.linalg.norm(n)), 1e-30)

    def sign(x: float) -> float:
        return float(np.sign(np.round(x, 12)))

    match shape:
        case Sphere(radius=r):
            return r * n
        case Box(size=size):
            return np.array([sign(n[i]) * size[i] / 2 for i in range(3)])
        case Plate(side=side):
            return np.array([sign(n[0]) * side / 2, 0.0, sign(n[2]) * side / 2])
        case Capsule(radius=r, length=length):
            return np.array([0.0, 0.0, sign(n[2]) * length / 2]) + r * n
        case Cylinder(radius=r, length=length):
            radial = np.array([n[0], n[1], 0.0])
            norm = float(np.linalg.norm(radial))
            rim = radial / norm * r if norm > 1e-12 else np.zeros(3)
            return np.array([0.0, 0.0, sign(n[2]) * length / 2]) + rim
    raise ValueError(f"{kind_of(shape)} has no support point")
