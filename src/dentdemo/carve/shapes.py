"""Shapes the carve and the indent tool know by name: their meshes and support points (local)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dentdemo.errors import DentdemoError
from dentdemo.mesh import primitives
from dentdemo.mesh.mesh import Mesh

SHAPES = ("plate", "box", "sphere", "capsule", "cylinder")


@dataclass(frozen=True)
class Shape:
    """A primitive: kind and dimensions in metres (see `dims` per kind)."""

    kind: str
    #: plate: (side,); box: (x, y, z) full extents; sphere: (radius,);
    #: capsule, cylinder: (radius, length) along local Z.
    dims: tuple[float, ...]

    def __post_init__(self) -> None:
        if self.kind not in SHAPES:
            raise DentdemoError(f"unknown shape '{self.kind}' (known: {', '.join(SHAPES)})")
        wanted = {"plate": 1, "box": 3, "sphere": 1, "capsule": 2, "cylinder": 2}[self.kind]
        if len(self.dims) != wanted:
            raise DentdemoError(f"a {self.kind} takes {wanted} size value(s), got {len(self.dims)}")
        if not all(np.isfinite(d) and d > 0 for d in self.dims):
            raise DentdemoError(
                f"{self.kind} sizes must be positive finite metres, got {self.dims}"
            )

    def mesh(self, detail: int = 1) -> Mesh:
        d = self.dims
        if self.kind == "plate":
            return primitives.plate(d[0])
        if self.kind == "box":
            return primitives.box((d[0], d[1], d[2]))
        if self.kind == "sphere":
            return primitives.sphere(d[0], subdivisions=24 * detail)
        if self.kind == "capsule":
            return primitives.capsule(d[0], d[1], around=48 * detail, rings=12 * detail)
        return primitives.cylinder(d[0], d[1], around=48 * detail)

    def support(self, direction: NDArray[np.float64]) -> NDArray[np.float64]:
        """The shape's farthest point along `direction` (local, metres; faces give their centre)."""
        n = np.asarray(direction, dtype=np.float64)
        n = n / max(float(np.linalg.norm(n)), 1e-30)
        d = self.dims
        if self.kind == "sphere":
            return d[0] * n
        if self.kind == "box":
            return np.sign(np.round(n, 12)) * np.asarray(d) / 2
        if self.kind == "plate":
            return np.array(
                [
                    np.sign(np.round(n[0], 12)) * d[0] / 2,
                    0.0,
                    np.sign(np.round(n[2], 12)) * d[0] / 2,
                ]
            )
        axis = np.array([0.0, 0.0, np.sign(np.round(n[2], 12)) * d[1] / 2])
        if self.kind == "capsule":
            return axis + d[0] * n
        radial = np.array([n[0], n[1], 0.0])
        norm = np.linalg.norm(radial)
        return axis + (radial / norm * d[0] if norm > 1e-12 else 0.0)
