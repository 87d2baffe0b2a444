"""Pass 1's footprint bound of built-in shapes (`mesh.Bound`: a swept sphere, or a few faces) for
many directions at once: `footprint.overlap`'s steps as numpy expressions over the directions
(and a shape's faces), each the same IEEE arithmetic in the same order as `footprint`'s on
Python floats, so a bound has the same bits worked out either way (`tests/test_carve_solids.py`):
numpy's price per call, paid once a step, undercuts Python's per float, paid once a direction,
only from some directions on (`ARRAY_BOUNDS`).

Camera coordinates as in `footprint`: x along `right`, y along `up`, s along the press, metres,
from each direction's origin. A value that does not exist (no face over a rectangle, a slab that
misses the solid) is NaN.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dentdemo.carve import lanes
from dentdemo.carve.lanes import Lane, Lanes3, Mode
from dentdemo.carve.linear import dot3
from dentdemo.mesh.mesh import Bound, Mesh

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]

#: Overlap extents no wider than this (metres) only touch: a solid tangent to a surface.
TOUCH_METRES = 1e-9

#: Directions of one pair of shape kinds from which their bounds are worked out as arrays
#: (`overlap_solids`), fewer one by one (`footprint.overlap`): measured on llvmpipe's VM
#: (docs/performance.md).
ARRAY_BOUNDS = 8


class Poses(NamedTuple):
    """Bodies posed in their directions' cameras, arrays over the directions: row k of
    `axes[i]` (3, 3) is the local vector whose dot product with a local point gives camera axis
    k (metres), `offset[i]` the camera coordinates of the local origin, `scale` the pose's
    scale (its largest column's length), `handed` +1, or -1 for a pose that mirrors."""

    axes: Array
    offset: Array
    scale: Array
    handed: Array

    def take(self, at: NDArray[np.int64]) -> Poses:
        return Poses(*(x[at] for x in self))


class PoseLanes(NamedTuple):
    """`Poses` as lanes (`carve/lanes.py`): `axes` three rows of lanes, `offset` one."""

    axes: tuple[Lanes3, Lanes3, Lanes3]
    offset: Lanes3
    scale: Lane
    handed: Lane

    def arrays(self, mode: Mode) -> Poses:
        """The same values as arrays over the directions."""
        if mode is lanes.ONE:  # one array of the direction's 14 floats, then views of it
            flat = np.array(
                [*self.axes[0], *self.axes[1], *self.axes[2], *self.offset, self.scale, self.handed]
            )
            return Poses(flat[:9].reshape(1, 3, 3), flat[9:12][None], flat[12:13], flat[13:14])
        axes, offset = np.array(self.axes, dtype=np.float64), np.array(self.offset)
        return Poses(
            np.ascontiguousarray(axes.transpose(2, 0, 1)),
            np.ascontiguousarray(offset.T),
            self.scale,
            self.handed,
        )


def pose_lanes(
    mode: Mode, axes: tuple[Lanes3, Lanes3, Lanes3], origin: Lanes3, model: Sequence[Sequence[Lane]]
) -> PoseLanes:
    """The `PoseLanes` of bodies posed at `model` (its rows' lanes: world from local, 3 x 4)
    in cameras whose rows `axes` (right, up, forward) and `origin` are lanes."""
    m = model
    local = tuple(
        (
            a[0] * m[0][0] + a[1] * m[1][0] + a[2] * m[2][0],
            a[0] * m[0][1] + a[1] * m[1][1] + a[2] * m[2][1],
            a[0] * m[0][2] + a[1] * m[1][2] + a[2] * m[2][2],
        )
        for a in axes
    )
    rel = (m[0][3] - origin[0], m[1][3] - origin[1], m[2][3] - origin[2])
    offset = (dot3(axes[0], rel), dot3(axes[1], rel), dot3(axes[2], rel))
    columns = [m[0][j] * m[0][j] + m[1][j] * m[1][j] + m[2][j] * m[2][j] for j in range(3)]
    scale = mode.sqrt(mode.greater(mode.greater(columns[0], columns[1]), columns[2]))
    det = (
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        + m[0][1] * (m[1][2] * m[2][0] - m[1][0] * m[2][2])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    )
    return PoseLanes(local, offset, scale, mode.where(det > 0.0, 1.0, -1.0))  # type: ignore[arg-type]


def points(axes: Array, offset: Array, local: Array) -> Array:
    """Camera coordinates (n, m, 3) of local points `local` ((m, 3), or (n, m, 3)) posed by
    `axes` (n, 3, 3) and `offset` (n, 3) (`Poses`), element by element in a fixed order (the
    same bits for one direction as for many)."""
    x, y, z = local[..., 0], local[..., 1], local[..., 2]
    return np.stack(
        [
            axes[:, k, 0, None] * x
            + axes[:, k, 1, None] * y
            + axes[:, k, 2, None] * z
            + offset[:, k, None]
            for k in range(3)
        ],
        axis=-1,
    )


def posed_floats(axes: Array, offset: Array, local: Array) -> list[list[float]]:
    """`points` of one direction on Python floats (a few points: numpy costs more per call):
    the same arithmetic in the same order, so the same bits."""
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = axes.tolist()
    o0, o1, o2 = offset.tolist()
    return [
        [
            a0 * x + a1 * y + a2 * z + o0,
            b0 * x + b1 * y + b2 * z + o1,
            c0 * x + c1 * y + c2 * z + o2,
        ]
        for x, y, z in local.tolist()
    ]


def outward_s(axes: Array, outward: Array) -> Array:
    """(n, k) the outward normals' (k, 3, or n, k, 3) s: positive multiples of the posed ones'
    (not turned over by a mirroring pose: a mirror moves the solid, not which side is out;
    `Projected._faces_towards` on floats)."""
    return (
        axes[:, 2, 0, None] * outward[..., 0]
        + axes[:, 2, 1, None] * outward[..., 1]
        + axes[:, 2, 2, None] * outward[..., 2]
    )


def solid_kind(mesh: Mesh) -> tuple[object, ...] | None:
    """Which directions' bodies `Solids` takes together: a swept sphere, or so many faces, and
    whether the mesh bounds a solid; None for a mesh without a `Bound` (`footprint.Projected`
    bounds it by its triangles)."""
    bound = mesh.bound
    if bound is None:
        return None
    if bound.segment is not None:
        return ("segment", mesh.encloses_volume())
    if bound.triangles is not None:
        return ("faces", len(bound.triangles), mesh.encloses_volume())
    return None


class Rects(NamedTuple):
    """Rectangles in camera x, y (metres), arrays over the directions; NaN: none."""

    x0: Array
    x1: Array
    y0: Array
    y1: Array


def _greater(a: Array, b: Array | float) -> Array:
    """Python's max(a, b), element by element (of two equal values, the first)."""
    return np.where(b > a, b, a)


def _lesser(a: Array, b: Array | float) -> Array:
    """Python's min(a, b), element by element."""
    return np.where(b < a, b, a)


class Solids:
    """One body of each of some directions, all of one `solid_kind`, in their cameras
    (`footprint.Projected`'s solid, for many directions)."""

    def __init__(self, bounds: Sequence[Bound], poses: Poses, solid: bool) -> None:
        self.solid = solid
        first = bounds[0]
        same = all(b is first for b in bounds)

        def local(values: list[Array]) -> Array:
            return values[0] if same else np.stack(values)

        #: (n, 2, 3) a swept sphere's segment and (n,) its radius, or (n, k, 3, 3) faces.
        self.segment: Array | None = None
        self.faces: Array | None = None
        self.radius = np.zeros(len(bounds))
        if first.segment is not None:
            self.segment = points(poses.axes, poses.offset, local([b.segment for b in bounds]))  # type: ignore[misc]
            self.radius = np.array([b.radius for b in bounds]) * poses.scale
            return
        faces = local([b.triangles for b in bounds])  # type: ignore[misc]
        k = faces.shape[-3]
        flat = faces.reshape(*faces.shape[:-3], 3 * k, 3)
        self.faces = points(poses.axes, poses.offset, flat).reshape(-1, k, 3, 3)
        self.outward_s = outward_s(poses.axes, local([b.outward for b in bounds]))  # type: ignore[misc]

    def rect(self) -> Rects:
        """The x, y extent of the whole solid (`Projected.rect`)."""
        if self.segment is not None:
            x, y, r = self.segment[..., 0], self.segment[..., 1], self.radius
            return Rects(
                _lesser(x[:, 0], x[:, 1]) - r,
                _greater(x[:, 0], x[:, 1]) + r,
                _lesser(y[:, 0], y[:, 1]) - r,
                _greater(y[:, 0], y[:, 1]) + r,
            )
        assert self.faces is not None
        n = len(self.faces)
        x, y = self.faces[..., 0].reshape(n, -1), self.faces[..., 1].reshape(n, -1)
        return Rects(x.min(1), x.max(1), y.min(1), y.max(1))

    def s_range(self) -> tuple[Array, Array]:
        """The s extent of the whole solid (`Projected.s_range`)."""
        if self.segment is not None:
            s = self.segment[..., 2]
            return _lesser(s[:, 0], s[:, 1]) - self.radius, _greater(s[:, 0], s[:, 1]) + self.radius
        assert self.faces is not None
        s = self.faces[..., 2].reshape(len(self.faces), -1)
        return s.min(1), s.max(1)

    def s_extreme(self, rect: Rects, lowest: bool) -> Array:
        """The lowest (or highest) s of the solid (a swept sphere: of all of it; faces: of their
        parts over `rect`; `Projected.s_extreme`), NaN where no face lies over it."""
        if self.segment is not None:
            s = self.segment[..., 2]
            return s.min(1) - self.radius if lowest else s.max(1) + self.radius
        assert self.faces is not None
        s = _clipped_extremes(self.faces, rect, lowest)
        if self.solid:
            # A closed convex solid's nearest (farthest) point along a view line is on a face
            # turned towards (away from) the camera, or edge-on (`Projected._faces_towards`).
            towards = self.outward_s <= 0.0 if lowest else self.outward_s >= 0.0
            s = np.where(towards, s, np.inf if lowest else -np.inf)
        found = s.min(1) if lowest else s.max(1)
        return np.where(np.isfinite(found), found, np.nan)

    def slab_part(self, lo: Array, hi: Array) -> Rects:
        """The x, y extent of the solid's part with lo <= s <= hi, NaN where it has none
        (`Projected.slab_part`)."""
        if self.segment is not None:
            return _swept_sphere_slab(self.segment, self.radius, lo, hi)
        assert self.faces is not None
        return _faces_slab(self.faces, lo, hi)


def _swept_sphere_slab(segment: Array, radius: Array, lo: Array, hi: Array) -> Rects:
    """`footprint.swept_sphere_slab` of each direction."""
    a, b = segment[:, 0], segment[:, 1]
    ds = b[:, 2] - a[:, 2]
    flat = np.abs(ds) < 1e-15
    safe = np.where(flat, 1.0, ds)
    ta, tb = (lo - radius - a[:, 2]) / safe, (hi + radius - a[:, 2]) / safe
    t0 = np.where(flat, 0.0, _greater(_lesser(ta, tb), 0.0))
    t1 = np.where(flat, 1.0, _lesser(_greater(ta, tb), 1.0))
    meets = np.where(flat, (lo - radius <= a[:, 2]) & (a[:, 2] <= hi + radius), t0 <= t1)
    p0 = a + t0[:, None] * (b - a)
    p1 = a + t1[:, None] * (b - a)
    near, far = _lesser(p0[:, 2], p1[:, 2]), _greater(p0[:, 2], p1[:, 2])
    # How far the nearest axis point lies outside the slab along s: the disc there is smallest.
    s_near = _lesser(_greater(lo, near), far)
    gap = _greater(_greater(lo - s_near, s_near - hi), 0.0)
    gap = np.where((near <= hi) & (far >= lo), 0.0, gap)
    reach = np.sqrt(_greater(radius * radius - gap * gap, 0.0))
    reach = np.where(meets, reach, np.nan)
    return Rects(
        _lesser(p0[:, 0], p1[:, 0]) - reach,
        _greater(p0[:, 0], p1[:, 0]) + reach,
        _lesser(p0[:, 1], p1[:, 1]) - reach,
        _greater(p0[:, 1], p1[:, 1]) + reach,
    )


#: A face's edges, as (from, to) corners.
_EDGES = ((0, 1), (1, 2), (2, 0))


def _faces_slab(faces: Array, lo: Array, hi: Array) -> Rects:
    """`footprint._faces_slab_rect` of each direction's faces (n, k, 3, 3): the extent of their
    corners inside the slab and, of those the slab cuts, of their edges' crossings of its
    planes."""
    lo2, hi2 = lo[:, None], hi[:, None]
    s = faces[..., 2]
    s_min, s_max = s.min(2), s.max(2)
    met = (s_max >= lo2) & (s_min <= hi2)
    cut = met & ((s_min < lo2) | (s_max > hi2))
    xs, ys = [faces[..., 0]], [faces[..., 1]]
    keep = [met[..., None] & (s >= lo2[..., None]) & (s <= hi2[..., None])]
    for i, j in _EDGES:
        a, b = faces[:, :, i], faces[:, :, j]
        span = b[..., 2] - a[..., 2]
        moves = np.abs(span) > 1e-300
        safe = np.where(moves, span, 1.0)
        for plane in (lo2, hi2):
            f = (plane - a[..., 2]) / safe
            keep.append(cut & moves & (f >= 0.0) & (f <= 1.0))
            xs.append(a[..., 0] + f * (b[..., 0] - a[..., 0]))
            ys.append(a[..., 1] + f * (b[..., 1] - a[..., 1]))
    n = len(faces)
    kept = np.concatenate([k.reshape(n, -1) for k in keep], axis=1)
    x = np.concatenate([v.reshape(n, -1) for v in xs], axis=1)
    y = np.concatenate([v.reshape(n, -1) for v in ys], axis=1)
    none = ~kept.any(axis=1)

    def extent(v: Array, lowest: bool) -> Array:
        found = np.where(kept, v, np.inf).min(1) if lowest else np.where(kept, v, -np.inf).max(1)
        return np.where(none, np.nan, found)

    return Rects(extent(x, True), extent(x, False), extent(y, True), extent(y, False))


def _clipped_extremes(faces: Array, rect: Rects, lowest: bool) -> Array:
    """(n, k) each face's lowest (highest) s over its direction's `rect` (inf, -inf where it
    has no part there): `footprint._clip_to_rect` (Sutherland-Hodgman: the planes x0, x1,
    y0, y1 in turn, each keeping a polygon's corners on its inner side and adding its edges'
    crossings, in order) on every face at once, the polygons held in rows of corners up to
    their count."""
    n, k = faces.shape[:2]
    polygon = faces.reshape(n * k, 3, 3)
    count = np.full(n * k, 3)
    planes = ((0, rect.x0, 1.0), (0, rect.x1, -1.0), (1, rect.y0, 1.0), (1, rect.y1, -1.0))
    for axis, value, sign in planes:
        corners = np.arange(polygon.shape[1])
        valid = corners < count[:, None]
        d = sign * (polygon[..., axis] - np.repeat(value, k)[:, None])
        after = (corners + 1) % np.maximum(count, 1)[:, None]
        following = np.take_along_axis(polygon, after[..., None], axis=1)
        d_next = np.take_along_axis(d, after, axis=1)
        inner = d >= 0
        crosses = valid & (inner != (d_next >= 0))
        t = d / np.where(crosses, d - d_next, 1.0)
        crossing = polygon + (following - polygon) * t[..., None]
        # Each corner, then its edge's crossing, where they are kept: the next polygon.
        candidates = np.stack([polygon, crossing], axis=2).reshape(n * k, -1, 3)
        emitted = np.stack([valid & inner, crosses], axis=2).reshape(n * k, -1)
        count = emitted.sum(axis=1)
        order = np.argsort(~emitted, axis=1, kind="stable")[:, : max(int(count.max()), 1)]
        polygon = np.take_along_axis(candidates, order[..., None], axis=1)
    held = np.arange(polygon.shape[1]) < count[:, None]
    if lowest:
        return np.where(held, polygon[..., 2], np.inf).min(1).reshape(n, k)
    return np.where(held, polygon[..., 2], -np.inf).max(1).reshape(n, k)


class Bounds(NamedTuple):
    """The footprint bound of some directions (`footprint.overlap` of each), arrays over them:
    the rectangle, the slab, and the whole bodies' s extents (the depth range); `meets` False
    where the bodies cannot meet (the other values are then meaningless)."""

    rect: Rects
    slab: tuple[Array, Array]
    target_s: tuple[Array, Array]
    tool_s: tuple[Array, Array]
    meets: Mask


def overlap_solids(
    target: Solids,
    tool: Solids,
    target_max_height: Array,
    tool_max_height: Array,
    advance: Array,
) -> Bounds:
    """`footprint.overlap` of each direction, on built-in solids: the same steps."""
    near_tool, near_target = tool.rect(), target.rect()
    s_lo = target.s_extreme(near_tool, lowest=True)  # the target's nearest point: first touch
    s_hi = tool.s_extreme(near_target, lowest=False)  # how far the advanced tool reaches
    meets = ~np.isnan(s_lo) & ~np.isnan(s_hi)
    bumps = _greater(target_max_height, 0.0) + _greater(tool_max_height, 0.0)
    # A solid tool's nearest point at first touch keeps a concave target's surfaces behind it
    # out of the slab (footprint.overlap).
    if tool.solid:
        tool_lo = tool.s_extreme(near_target, lowest=True)
        s_lo = np.where(np.isnan(tool_lo), s_lo, _greater(s_lo, tool_lo - advance - bumps))
    meets &= ~(s_hi + bumps < s_lo)
    target_rect = target.slab_part(s_lo, s_hi + bumps)
    tool_rect = tool.slab_part(s_lo - bumps, s_hi)
    rect = Rects(
        _greater(target_rect.x0, tool_rect.x0),
        _lesser(target_rect.x1, tool_rect.x1),
        _greater(target_rect.y0, tool_rect.y0),
        _lesser(target_rect.y1, tool_rect.y1),
    )
    # Extents that only touch hold no overlap (TOUCH_METRES: a tangent solid's rounding).
    meets &= ~np.isnan(target_rect.x0) & ~np.isnan(tool_rect.x0)
    meets &= (rect.x0 <= rect.x1) & (rect.y0 <= rect.y1)
    meets &= _lesser(rect.x1 - rect.x0, rect.y1 - rect.y0) > TOUCH_METRES
    return Bounds(rect, (s_lo, s_hi + bumps), target.s_range(), tool.s_range(), meets)
