"""Triangle lists of built-in spheres from their cube-sphere atlas in closed form, for a batch's
queries at once (`footprint.lists_many`): no cluster search.

A query asks for the triangles whose bounding sphere meets a box (camera x, y, s, metres:
`footprint.meeting_many`). A triangle's bounding-sphere centre lies in the box grown by the
largest such radius and inside the sphere, so its direction from the sphere's centre is the
central projection of a point of that box; on a cube face whose half-space holds the whole
box, those directions project into the convex hull of the projected corners (a central
projection keeps segments straight there). The hull's extent in the face's gnomonic
coordinates (X = tan(s pi / 4) along the face's a axis, Y along b: `mesh/cube.py`) gives the
rows and columns of the face's equal-angle cells that hold every such triangle, one cell more
each side for rounding; a face whose half-space holds part of the box gives all of its cells.
Those cells' triangles are the candidates; with `exact`, their bounding spheres are then
tested against the box as `meeting_many` tests them, element by element, so a query's list
is the same alone and in any batch.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from dentdemo.mesh.cube import CUBE_FACES, grid_tangents

if TYPE_CHECKING:
    from dentdemo.carve.footprint import Projected, Query
    from dentdemo.mesh.mesh import Mesh

Array = NDArray[np.float64]
Indices = NDArray[np.int64]

_NORMAL, _ACROSS, _ALONG = (
    np.array([face[k] for face in CUBE_FACES], dtype=np.float64) for k in range(3)
)


def closed_form(mesh: Mesh) -> bool:
    """Whether `mesh` is a built-in sphere whose triangles are still those its cube atlas laid
    out, so its lists come from `cube_lists`."""
    return mesh.laid_as_cube_sphere()


def cube_lists(queries: Sequence[Query]) -> list[Indices]:
    """The triangles of the cells each query's box projects into (all queries on one built-in
    sphere mesh): every triangle whose bounding sphere meets the box, and those beside them in
    the cells' rows and columns."""
    if not queries:
        return []
    mesh = queries[0][0]._mesh
    n = mesh.bound.grid  # type: ignore[union-attr]
    reach = mesh.triangle_reach()
    solid = mesh.bound.radius  # type: ignore[union-attr]
    if len(queries) < ARRAY_QUERIES:
        return [
            _triangles_one(_cells_one(p, [r.x0, r.x1, r.y0, r.y1, lo, hi], reach, solid, n), n)
            for p, r, (lo, hi) in queries
        ]
    tris: list[Projected] = [q[0] for q in queries]
    axes = np.array([p._local_axes for p in tris])  # (q, 3, 3): rows give camera axes
    offset = np.array([p._offset for p in tris])  # the sphere's centre in camera coordinates
    scale = np.array([p._scale for p in tris])
    boxes = np.array([(r.x0, r.x1, r.y0, r.y1, lo, hi) for _, r, (lo, hi) in queries])
    each: list[list[tuple[int, int, int, int, int]]] = [[] for _ in queries]
    blocks = _cell_blocks(axes, offset, scale, boxes, reach, solid, n).tolist()
    for q, face, r0, rows, c0, cols in blocks:
        each[q].append((face, r0, rows, c0, cols))
    return [_triangles_one(blocks, n) for blocks in each]


def _triangles_one(blocks: list[tuple[int, int, int, int, int]], n: int) -> Indices:
    """The triangles of one query's blocks (face, row from, rows, column from, columns), in
    order: a face holds its cells' lower halves, row by row, then their upper halves."""
    parts = [
        (
            np.arange(2)[:, None, None] * (n * n)
            + (face * 2 * n * n + np.arange(r0 * n, (r0 + rows) * n, n))[None, :, None]
            + np.arange(c0, c0 + cols)[None, None, :]
        ).ravel()
        for face, r0, rows, c0, cols in blocks
    ]
    if not parts:
        return np.zeros(0, dtype=np.int64)
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


#: Queries of one sphere from which their cells are found as arrays (`_cell_blocks`), fewer one
#: by one on Python floats (`_cells_one`: the same arithmetic, so the same cells).
ARRAY_QUERIES = 20


def _cells_one(
    projected: Projected, box: list[float], reach: float, radius: float, n: int
) -> list[tuple[int, int, int, int, int]]:
    """`_cell_blocks` of one query on Python floats: its blocks (face, row from, rows, column
    from, columns)."""
    scale = projected._scale
    grow, solid = reach * scale, (reach + radius) * scale
    near = _near(radius, reach)
    rows = projected._local_axes.tolist()
    offset = projected._offset.tolist()
    lo = [max(box[2 * k] - grow, offset[k] - solid) for k in range(3)]
    hi = [min(box[2 * k + 1] + grow, offset[k] + solid) for k in range(3)]
    if not all(a <= b for a, b in zip(lo, hi, strict=True)):
        return []
    square = scale * scale
    corners = []
    for i in range(8):
        c = [(hi[k] if i >> (2 - k) & 1 else lo[k]) - offset[k] for k in range(3)]
        corners.append(
            [(rows[0][j] * c[0] + rows[1][j] * c[1] + rows[2][j] * c[2]) / square for j in range(3)]
        )
    tangents = grid_tangents(n)
    blocks = []
    # Most boxes lie well inside one face's pyramid: then no other face's cells are found.
    middle = [sum(c[j] for c in corners) for j in range(3)]
    main = max(range(6), key=lambda f: _dot3(CUBE_FACES[f][0], middle))
    for face in [main] + [f for f in range(6) if f != main]:
        normal, across_axis, along_axis = CUBE_FACES[face]
        depth = [_dot3(normal, c) for c in corners]
        across = [_dot3(across_axis, c) for c in corners]
        along = [_dot3(along_axis, c) for c in corners]
        points = [
            (b / d, a / d)
            for d, a, b in zip(depth, across, along, strict=True)
            if d >= near  # (along, across) over depth: rows, then columns
        ]
        for i, j in _BOX_EDGES:
            if (depth[i] >= near) != (depth[j] >= near):
                t = (near - depth[i]) / (depth[j] - depth[i])
                d = depth[i] + t * (depth[j] - depth[i])
                a = across[i] + t * (across[j] - across[i])
                b = along[i] + t * (along[j] - along[i])
                points.append((b / d, a / d))
        block = _block(face, points, tangents, n)
        if block is not None:
            blocks.append(block)
        if face == main and all(
            d > _WELL_INSIDE * max(abs(a), abs(b))
            for d, a, b in zip(depth, across, along, strict=True)
        ):
            break
    blocks.sort()
    return blocks


def _block(
    face: int, points: list[tuple[float, float]], tangents: tuple[float, ...], n: int
) -> tuple[int, int, int, int, int] | None:
    """The block of cells of `face` (face, row from, rows, column from, columns) over the
    gnomonic points (along, across) `points`, one cell more each side; None where they all
    lie off the face."""
    if not points:
        return None
    g0, g1 = min(p[0] for p in points), max(p[0] for p in points)
    h0, h1 = min(p[1] for p in points), max(p[1] for p in points)
    if g1 < -1.0 or g0 > 1.0 or h1 < -1.0 or h0 > 1.0:
        return None
    r0, r1 = max(bisect_right(tangents, g0) - 2, 0), min(bisect_right(tangents, g1), n - 1)
    c0, c1 = max(bisect_right(tangents, h0) - 2, 0), min(bisect_right(tangents, h1), n - 1)
    return face, r0, r1 - r0 + 1, c0, c1 - c0 + 1


def _near(radius: float, reach: float) -> float:
    """The least depth along a face's normal of a triangle's bounding-sphere centre in that
    face's cells (local metres, a little less for rounding): on a face, the depth is at least
    the distance from the centre over sqrt(3), and a centre lies within `reach` of its
    triangle's corners, which lie on the sphere."""
    return 0.999 * (radius - reach) / math.sqrt(3.0)


#: A box's edges, as pairs of its corners (corner i: bit 2 - k of i picks axis k's high side).
_BOX_EDGES = tuple((i, i | bit) for i in range(8) for bit in (4, 2, 1) if not i & bit)

#: How far inside one face's pyramid a box's corners must all lie (depth over the larger of
#: across and along) for `_cells_one` to look at no other face: far enough that no rounding
#: brings another face's gnomonic coordinates back to 1.
_WELL_INSIDE = 1.01


def _dot3(a: tuple[int, ...], b: list[float]) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cell_blocks(
    axes: Array, offset: Array, scale: Array, boxes: Array, reach: float, radius: float, n: int
) -> NDArray[np.int64]:
    """(b, 6) the blocks of cells (query, face, row from, rows, column from, columns) that hold
    every triangle of a built-in sphere of local `radius` and `n` cells a face edge whose
    bounding sphere (of local radius up to `reach`) may meet each query's box (`cube_lists`)."""
    grow = reach * scale
    solid = (reach + radius) * scale  # the centres lie within the sphere
    lo = np.maximum(boxes[:, 0::2] - grow[:, None], offset - solid[:, None])
    hi = np.minimum(boxes[:, 1::2] + grow[:, None], offset + solid[:, None])
    meets = np.all(lo <= hi, axis=1)
    # The box's corners, local (the pose's linear part is a rotation times the scale: its
    # inverse is its transpose over the scale squared).
    pick = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=bool)
    corners = np.where(pick[None], hi[:, None, :], lo[:, None, :]) - offset[:, None, :]
    # Element by element (a query's cells do not depend on the rest of its batch).
    square = (scale * scale)[:, None]
    local = [
        (
            axes[:, 0, j, None] * corners[..., 0]
            + axes[:, 1, j, None] * corners[..., 1]
            + axes[:, 2, j, None] * corners[..., 2]
        )
        / square
        for j in range(3)
    ]
    tangents = np.array(grid_tangents(n))
    near = _near(radius, reach)
    first, second = (np.array(e) for e in zip(*_BOX_EDGES, strict=True))
    found = []
    for face in range(6):
        depth = _dot(_NORMAL[face], local)
        across, along = _dot(_ACROSS[face], local), _dot(_ALONG[face], local)
        kept = depth >= near
        # Where an edge of the box crosses depth = near (`_cells_one`).
        d0, d1 = depth[:, first], depth[:, second]
        crosses = kept[:, first] != kept[:, second]
        t = (near - d0) / np.where(crosses, d1 - d0, 1.0)
        d = np.where(crosses, d0 + t * (d1 - d0), 1.0)
        a = across[:, first] + t * (across[:, second] - across[:, first])
        b = along[:, first] + t * (along[:, second] - along[:, first])
        safe = np.where(kept, depth, 1.0)
        held = np.concatenate([kept, crosses], axis=1)
        rows = np.concatenate([along / safe, b / d], axis=1)
        cols = np.concatenate([across / safe, a / d], axis=1)
        g0, g1 = np.where(held, rows, np.inf).min(1), np.where(held, rows, -np.inf).max(1)
        h0, h1 = np.where(held, cols, np.inf).min(1), np.where(held, cols, -np.inf).max(1)
        on = meets & held.any(axis=1) & (g1 >= -1.0) & (g0 <= 1.0) & (h1 >= -1.0) & (h0 <= 1.0)
        (q,) = np.nonzero(on)
        r0 = np.maximum(np.searchsorted(tangents, g0[q], side="right") - 2, 0)
        r1 = np.minimum(np.searchsorted(tangents, g1[q], side="right"), n - 1)
        c0 = np.maximum(np.searchsorted(tangents, h0[q], side="right") - 2, 0)
        c1 = np.minimum(np.searchsorted(tangents, h1[q], side="right"), n - 1)
        found.append(np.stack([q, np.full(len(q), face), r0, r1 - r0 + 1, c0, c1 - c0 + 1], 1))
    blocks = np.concatenate(found).astype(np.int64)
    return blocks[np.lexsort((blocks[:, 1], blocks[:, 0]))]


def _dot(a: Array, b: list[Array]) -> Array:
    """The 3-vector `a` dotted with the vectors whose components are `b`'s arrays, element by
    element in a fixed order."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
