"""The cube atlas that built-in boxes and cube-spheres share: six faces, each an n x n grid of
cells two triangles each, in one chart of a 3 x 2 atlas (`primitives`), and where a ray from a
cube-sphere's centre crosses it. Local metres."""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import NDArray

# Cube faces as (normal, a, b) with a x b = normal; a runs along +u, b along +v of the face chart.
CUBE_FACES = (
    ((1, 0, 0), (0, 0, -1), (0, 1, 0)),
    ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
    ((0, 1, 0), (1, 0, 0), (0, 0, -1)),
    ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
    ((0, 0, 1), (1, 0, 0), (0, 1, 0)),
    ((0, 0, -1), (-1, 0, 0), (0, 1, 0)),
)


def grid_indices(rows: int, cols: int, offset: int) -> np.ndarray:
    """Two triangles per cell of a (rows+1) x (cols+1) vertex grid laid out row by row."""
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    i0 = (offset + r * (cols + 1) + c).ravel()
    i1, i2, i3 = i0 + 1, i0 + cols + 1, i0 + cols + 2
    return np.concatenate([np.stack([i0, i1, i3], 1), np.stack([i0, i3, i2], 1)])


def cube_triangle(point: tuple[float, float, float], n: int) -> int:
    """The triangle of `primitives.sphere(radius, subdivisions=n)` that the ray from its centre
    through `point` (local metres) crosses: the cube face (`CUBE_FACES`) the ray is most along,
    then its cell of the face's n x n equal-angle grid (s = atan(a / depth) 4 / pi across, t
    the same along b: a grid line of one s or t is a great circle, so the cell is exact), then
    the half of the cell on the ray's side of the plane through the centre and the cell's
    diagonal, which runs from its low (s, t) corner to its high one. Each face holds 2 n^2
    triangles, the cells' lower halves row by row, then their upper halves
    (`cube_atlas_indices`). On Python floats: one point."""
    x, y, z = point
    ax, ay, az = abs(x), abs(y), abs(z)
    if ax >= ay and ax >= az:
        face = 0 if x >= 0.0 else 1
    elif ay >= az:
        face = 2 if y >= 0.0 else 3
    else:
        face = 4 if z >= 0.0 else 5
    normal, across, along = CUBE_FACES[face]
    depth = max(_dot3(point, normal), 1e-300)  # 0 only at the centre
    quarter = math.pi / 4.0
    fx = (math.atan(_dot3(point, across) / depth) / quarter + 1.0) * (n / 2.0)
    fy = (math.atan(_dot3(point, along) / depth) / quarter + 1.0) * (n / 2.0)
    col, row = min(max(math.floor(fx), 0), n - 1), min(max(math.floor(fy), 0), n - 1)

    tangents = grid_tangents(n)

    def corner(c: int, r: int) -> tuple[float, float, float]:
        """The direction of the grid's vertex at column c, row r (not unit)."""
        ts, tt = tangents[c], tangents[r]
        return (
            normal[0] + ts * across[0] + tt * along[0],
            normal[1] + ts * across[1] + tt * along[1],
            normal[2] + ts * across[2] + tt * along[2],
        )

    (ux, uy, uz), (vx, vy, vz) = corner(col, row), corner(col + 1, row + 1)
    m = (uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx)  # the diagonal's plane
    upper = _dot3(point, m) * _dot3(corner(col + 1, row), m) < 0.0  # not the lower corner's side
    return face * 2 * n * n + upper * n * n + row * n + col


@functools.cache
def grid_tangents(n: int) -> tuple[float, ...]:
    """tan(s pi / 4) at each of the n + 1 grid lines s = 2 k / n - 1 of a cube-sphere face."""
    return tuple(math.tan((2.0 * k / n - 1.0) * math.pi / 4.0) for k in range(n + 1))


def _dot3(a: tuple[float, ...], b: tuple[float, ...]) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cube_atlas_indices(n: int) -> NDArray[np.int64]:
    """The triangles (vertex indices, (12 n^2, 3)) of a cube atlas of n x n cells a face (a
    cube-sphere, a box) before `Mesh` turns any of them outward: each face's (n + 1)^2
    vertices row by row, two triangles a cell."""
    return np.vstack([grid_indices(n, n, face * (n + 1) ** 2) for face in range(6)])
