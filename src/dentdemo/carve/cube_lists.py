"""Triangle lists of built-in spheres from their cube-sphere atlas in closed form, for a batch's
queries at once (`footprint.lists_many`): no cluster or triangle test.

A query asks for the triangles whose bounding sphere meets a box (camera x, y, s, metres:
`footprint.meeting_many`). Such a triangle's bounding-sphere centre lies in the box grown by the
largest such radius (`Mesh.triangle_reach`), and a centre in a cube face's cells lies at least
`_near` deep along that face's normal. The part of the grown box that deep is convex and in
front of the sphere's centre, so the directions of its points project onto the face's plane
into the convex hull of the projections of its vertices (the box's corners that deep and its
edges' crossings of that depth). The hull's extent in the face's gnomonic coordinates
(X = tan(s pi / 4) along the face's a axis, Y along b: `mesh/cube.py`) covers rows and columns
of the face's equal-angle cells, found among the grid lines' tangents by bisection (exact
comparisons, the same on floats and arrays); the triangles of those cells are the list: every
triangle whose bounding sphere meets the box, and the cells' other triangles.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Sequence
from itertools import product
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from dentdemo.mesh.cube import CUBE_FACES, grid_tangents

if TYPE_CHECKING:
    from dentdemo.carve.footprint import Projected, Query
    from dentdemo.mesh.mesh import Mesh

Array = NDArray[np.float64]
Indices = NDArray[np.int64]

#: Each cube face's normal, a and b axes (`CUBE_FACES`: signed unit axes) as (axis, sign).
_FACE_AXES = tuple(
    tuple((max(range(3), key=lambda k: abs(v[k])), float(sum(v))) for v in face)
    for face in CUBE_FACES
)


def closed_form(mesh: Mesh) -> bool:
    """Whether `mesh` is a built-in sphere whose triangles are still those its cube atlas laid
    out, so its lists come from `cube_lists`."""
    return mesh.laid_as_cube_sphere()


def cube_lists(queries: Sequence[Query], exact: bool) -> list[Indices]:
    """The triangles of the cells each query's box projects into (all queries on one built-in
    sphere mesh): every triangle whose bounding sphere meets the box, and the cells' others;
    with `exact`, only those that meet it (`meeting_many`'s test, on the cells' triangles)."""
    if not queries:
        return []
    mesh = queries[0][0]._mesh
    n = mesh.bound.grid  # type: ignore[union-attr]
    reach = mesh.triangle_reach()
    solid = mesh.bound.radius  # type: ignore[union-attr]
    if len(queries) < ARRAY_QUERIES:
        each = [
            _cells_one(p, [r.x0, r.x1, r.y0, r.y1, lo, hi], reach, solid, n)
            for p, r, (lo, hi) in queries
        ]
    else:
        tris: list[Projected] = [q[0] for q in queries]
        axes = np.array([p._local_axes for p in tris])  # (q, 3, 3): rows give camera axes
        offset = np.array([p._offset for p in tris])  # the sphere's centre, camera coordinates
        scale = np.array([p._scale for p in tris])
        boxes = np.array([(r.x0, r.x1, r.y0, r.y1, lo, hi) for _, r, (lo, hi) in queries])
        each = [[] for _ in queries]
        for q, face, r0, rows, c0, cols in _cell_blocks(
            axes, offset, scale, boxes, reach, solid, n
        ).tolist():
            each[q].append((face, r0, rows, c0, cols))
    lists = [_triangles_one(blocks, n) for blocks in each]
    if exact:
        lists = [_meeting(query, which) for query, which in zip(queries, lists, strict=True)]
    return lists


def _meeting(query: Query, which: Indices) -> Indices:
    """Those of triangles `which` whose bounding sphere meets the query's box, by
    `meeting_many`'s arithmetic (the camera coordinates by `Projected._to_camera`)."""
    projected, rect, (lo, hi) = query
    centre, radius = projected._mesh.triangle_spheres()
    x, y, s = projected._to_camera(centre[which]).T
    r = radius[which] * projected._scale
    meets = x + r >= rect.x0
    meets &= x - r <= rect.x1
    meets &= y + r >= rect.y0
    meets &= y - r <= rect.y1
    meets &= s + r >= lo
    meets &= s - r <= hi
    return which[meets]


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
    (r0, r1, r2), (s0, s1, s2), (t0, t1, t2) = rows
    corners = []
    for x, y, z in product(*zip(lo, hi, strict=True)):  # corner i: bit 2 - k picks axis k's hi
        x, y, z = x - offset[0], y - offset[1], z - offset[2]
        corners.append(
            (
                (r0 * x + s0 * y + t0 * z) / square,
                (r1 * x + s1 * y + t1 * z) / square,
                (r2 * x + s2 * y + t2 * z) / square,
            )
        )
    tangents = grid_tangents(n)
    blocks = []
    # Most boxes lie well inside one face's pyramid (the one the box's middle points to): then
    # no other face's cells are found.
    middle = [sum(c[k] for c in corners) for k in range(3)]
    axis = max(range(3), key=lambda k: abs(middle[k]))
    main = 2 * axis + (middle[axis] < 0.0)
    for face in [main] + [f for f in range(6) if f != main]:
        (ni, ns), (ai, as_), (bi, bs) = _FACE_AXES[face]
        depth = [ns * c[ni] for c in corners]
        across = [as_ * c[ai] for c in corners]
        along = [bs * c[bi] for c in corners]
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
    gnomonic points (along, across) `points`; None where they all lie off the face."""
    if not points:
        return None
    g0, g1 = min(p[0] for p in points), max(p[0] for p in points)
    h0, h1 = min(p[1] for p in points), max(p[1] for p in points)
    if g1 < -1.0 or g0 > 1.0 or h1 < -1.0 or h0 > 1.0:
        return None
    r0 = max(bisect_right(tangents, g0 - _SLACK) - 1, 0)
    r1 = min(bisect_right(tangents, g1 + _SLACK) - 1, n - 1)
    c0 = max(bisect_right(tangents, h0 - _SLACK) - 1, 0)
    c1 = min(bisect_right(tangents, h1 + _SLACK) - 1, n - 1)
    return face, r0, r1 - r0 + 1, c0, c1 - c0 + 1


def _near(radius: float, reach: float) -> float:
    """The least depth along a face's normal of a triangle's bounding-sphere centre in that
    face's cells (local metres, a little less for rounding): on a face, the depth is at least
    the distance from the centre over sqrt(3), and a centre lies within `reach` of its
    triangle's corners, which lie on the sphere."""
    return 0.999 * (radius - reach) / math.sqrt(3.0)


#: How far (gnomonic units) a block reaches past the points it covers, for their rounding: a
#: triangle's centre lies inside its cell by far more.
_SLACK = 1e-9

#: A box's edges, as pairs of its corners (corner i: bit 2 - k of i picks axis k's high side).
_BOX_EDGES = tuple((i, i | bit) for i in range(8) for bit in (4, 2, 1) if not i & bit)

#: How far inside one face's pyramid a box's corners must all lie (depth over the larger of
#: across and along) for `_cells_one` to look at no other face: far enough that no rounding
#: brings another face's gnomonic coordinates back to 1.
_WELL_INSIDE = 1.01


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
        (ni, ns), (ai, as_), (bi, bs) = _FACE_AXES[face]
        depth, across, along = ns * local[ni], as_ * local[ai], bs * local[bi]
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
        r0 = np.maximum(np.searchsorted(tangents, g0[q] - _SLACK, side="right") - 1, 0)
        r1 = np.minimum(np.searchsorted(tangents, g1[q] + _SLACK, side="right") - 1, n - 1)
        c0 = np.maximum(np.searchsorted(tangents, h0[q] - _SLACK, side="right") - 1, 0)
        c1 = np.minimum(np.searchsorted(tangents, h1[q] + _SLACK, side="right") - 1, n - 1)
        found.append(np.stack([q, np.full(len(q), face), r0, r1 - r0 + 1, c0, c1 - c0 + 1], 1))
    blocks = np.concatenate(found).astype(np.int64)
    return blocks[np.lexsort((blocks[:, 1], blocks[:, 0]))]
