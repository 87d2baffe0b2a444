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

from dentdemo.errors import ArgumentError


def _positive(value: object) -> bool:
    """Whether `value` is a positive finite real number (not a bool)."""
    real = isinstance(value, int | float | np.floating | np.integer)
    return real and not isinstance(value, bool) and math.isfinite(value) and value > 0  # type: ignore[arg-type, operator]


def _size(shape: object, name: str, value: object) -> None:
    """Check that field `name` of `shape` is a positive finite number of metres; store a float."""
    if not _positive(value):
        raise ArgumentError(
            f"{type(shape).__name__} {name} must be a positive finite number of metres, "
            f"got {value!r}"
        )
    object.__setattr__(shape, name, float(value))  # type: ignore[arg-type]


@dataclass(frozen=True)
class Sphere:
    radius: float

    def __post_init__(self) -> None:
        _size(self, "radius", self.radius)

    def volume(self) -> float:
        return 4.0 / 3.0 * math.pi * self.radius**3

    def bounding_radius(self) -> float:
        return self.radius


@dataclass(frozen=True)
class Box:
    #: Full extents along local x, y, z.
    size: tuple[float, float, float]

    def __post_init__(self) -> None:
        edges = list(self.size) if _sequence(self.size) else []
        if len(edges) != 3 or not all(_positive(x) for x in edges):
            raise ArgumentError(
                "Box size must be 3 positive finite edge lengths (x, y, z) in metres, "
                f"got {self.size!r}"
            )
        object.__setattr__(self, "size", tuple(float(x) for x in edges))

    def volume(self) -> float:
        return float(np.prod(self.size))

    def bounding_radius(self) -> float:
        return float(np.linalg.norm(self.size) / 2)


@dataclass(frozen=True)
class Capsule:
    """A cylinder of `length` along local Z with hemispherical caps of `radius`."""

    radius: float
    length: float

    def __post_init__(self) -> None:
        _size(self, "radius", self.radius)
        _size(self, "length", self.length)

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

    def __post_init__(self) -> None:
        _size(self, "radius", self.radius)
        _size(self, "length", self.length)

    def volume(self) -> float:
        return math.pi * self.radius**2 * self.length

    def bounding_radius(self) -> float:
        return math.hypot(self.length / 2, self.radius)


@dataclass(frozen=True)
class Plate:
    """A side x thickness x side box whose top face (local y = 0) carries the dentable map."""

    side: float
    thickness: float = 0.02

    def __post_init__(self) -> None:
        _size(self, "side", self.side)
        _size(self, "thickness", self.thickness)

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

    def __post_init__(self) -> None:
        if not isinstance(self.path, str) or not self.path:
            raise ArgumentError(f"MeshFile path must be a file name, got {self.path!r}")
        try:
            _size(self, "scale", self.scale)
        except ArgumentError:
            raise ArgumentError(
                f"MeshFile scale must be a positive finite number, got {self.scale!r}"
            ) from None

    def volume(self) -> float:
        return 0.0

    def bounding_radius(self) -> float:
        return math.inf


#: The largest share of its area a mesh's holes may span for it to count as enclosing a volume
#: (a dynamic body's mass comes from that volume): scanning holes pass, a sheet or a bowl does not.
MAX_OPEN_SHARE = 0.01


def mesh_volume(positions: NDArray, indices: NDArray) -> tuple[float, float]:
    """(volume, open share) of a triangle mesh. The volume, m^3, is signed (positive for
    outward faces) and taken about the mesh's bounding-box centre. The open share is
    |sum of the triangles' vector areas| / their total area: 0 for a closed surface (the vector
    areas of a closed surface cancel), 1 for a flat sheet; a mesh with holes has a volume that
    depends on the point it is taken about, by up to about this share."""
    p = np.asarray(positions, dtype=np.float64)
    p = (p - (p.min(axis=0) + p.max(axis=0)) / 2)[np.asarray(indices, dtype=np.int64)]
    doubled = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])  # twice each vector area
    total = float(np.linalg.norm(doubled, axis=1).sum())
    open_share = float(np.linalg.norm(doubled.sum(axis=0))) / total if total > 0 else 1.0
    volume = float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0)
    return volume, open_share


def _sequence(value: object) -> bool:
    return isinstance(value, tuple | list | np.ndarray)


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
