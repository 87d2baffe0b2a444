"""Pass 1's bound on a press's overlap, from both bodies' triangles (CPU, numpy).

Coordinates here are the collision camera's, in metres: x along `right`, y along `up`, s along the
press direction (`forward`) from the contact point. At first touch the bodies are separated by the
plane s = s_lo (the target's nearest point) and the advanced tool reaches s_hi: the overlap lies in
the slab s_lo <= s <= s_hi of both, widened by the bumps the maps hold. The camera's rectangle is
the intersection of the projections of what of each body lies in its slab. Per-triangle clipping
makes it tight for any mesh and conservative by construction (a triangle's extent over a slab is
that of its clipped polygon, whose corners are its vertices inside the slab and its edges'
crossings of the slab's planes). Bounding spheres of the triangles only pick which triangles get
that exact test, so a hit's CPU work follows the triangles near the footprint.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from dentdemo.carve.cube_lists import closed_form, cube_lists
from dentdemo.carve.lanes import ONE
from dentdemo.carve.solids import Poses, pose_lanes, posed_floats
from dentdemo.mesh.mesh import Mesh

Array = NDArray[np.float64]
Indices = NDArray[np.int64]

#: Overlap extents no wider than this (metres) only touch: a solid tangent to a surface.
TOUCH_METRES = 1e-9


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle in camera x, y (metres)."""

    x0: float
    x1: float
    y0: float
    y1: float

    def intersect(self, other: Rect) -> Rect | None:
        r = Rect(
            max(self.x0, other.x0),
            min(self.x1, other.x1),
            max(self.y0, other.y0),
            min(self.y1, other.y1),
        )
        return r if r.x0 <= r.x1 and r.y0 <= r.y1 else None

    def grown(self, margin: float) -> Rect:
        return Rect(self.x0 - margin, self.x1 + margin, self.y0 - margin, self.y1 + margin)


@dataclass(frozen=True)
class Overlap:
    """Where a press can change a map: the rectangle and the slab of s (metres)."""

    rect: Rect
    #: s range that holds every target surface point the press can move.
    slab: tuple[float, float]


class Projected:
    """A posed mesh's triangles in camera coordinates. Queries test the bounding spheres of
    triangle clusters, then of the triangles in the clusters that pass, then exact corners for
    the few triangles that need them: a hit's CPU work follows the triangles near the footprint."""

    def __init__(self, mesh: Mesh, model: Array, origin: Array, axes: Array) -> None:
        rows = np.asarray(axes, dtype=np.float64).tolist()
        model_rows = np.asarray(model, dtype=np.float64)[:3].tolist()
        o = np.asarray(origin, dtype=np.float64).tolist()
        pose = pose_lanes(ONE, (rows[0], rows[1], rows[2]), (o[0], o[1], o[2]), model_rows)
        self._posed(mesh, pose.arrays(ONE), 0)

    @classmethod
    def of(cls, mesh: Mesh, pose: Poses, at: int) -> Projected:
        """`mesh` posed as direction `at` of `pose` (`solids.Poses`: a batch's poses at once,
        each with the bits it has alone)."""
        made = cls.__new__(cls)
        made._posed(mesh, pose, at)
        return made

    def _posed(self, mesh: Mesh, pose: Poses, at: int) -> None:
        #: Row k: the local vector whose dot product gives camera axis k.
        self._local_axes = pose.axes[at]
        self._offset = pose.offset[at]
        #: The pose's scale: poses are rotations times a uniform scale.
        self._scale = float(pose.scale[at])
        #: +1, or -1 for a pose that mirrors (its windings turn over).
        self._handed = float(pose.handed[at])
        self._mesh = mesh
        bound = mesh.bound
        self._radius = 0.0 if bound is None else bound.radius * self._scale
        #: Whether the mesh bounds a solid (see Mesh.encloses_volume).
        self.solid = mesh.encloses_volume()
        self._s_range: tuple[float, float] | None = None
        self._rect: Rect | None = None

    @cached_property
    def _segment(self) -> Array | None:
        """A built-in shape's solid: a swept sphere's segment (2, 3), camera coordinates."""
        bound = self._mesh.bound
        if bound is None or bound.segment is None:
            return None
        return np.array(posed_floats(self._local_axes, self._offset, bound.segment))

    @cached_property
    def _faces(self) -> Array | None:
        """A built-in shape's few faces (k, 3, 3), camera coordinates."""
        bound = self._mesh.bound
        if bound is None or bound.triangles is None:
            return None
        flat = posed_floats(self._local_axes, self._offset, bound.triangles.reshape(-1, 3))
        return np.array(flat).reshape(bound.triangles.shape)

    @cached_property
    def _clusters(self) -> tuple[Array, Array, NDArray[np.int64]]:
        """The mesh's triangle clusters in camera coordinates: centres (k, 3), radii (k,),
        members (k, CLUSTER_SIZE); made when a query first needs them (a built-in shape's
        extents come from its solid)."""
        centre, radius, members = self._mesh.clusters()
        return self._to_camera(centre), radius * self._scale, members

    def _to_camera(self, local: Array) -> Array:
        flat = local.reshape(-1, 3) @ self._local_axes.T
        flat += self._offset
        return flat.reshape(local.shape)

    def corners(self, which: Indices) -> Array:
        """(k, 3, 3) camera (x, y, s) of the corners of triangles `which`."""
        return self._to_camera(self._mesh.corner_array().take(which, axis=0))

    def faces_away(self, which: Indices, away: bool = True) -> bool:
        """Whether any of triangles `which` faces away from the camera (its outward normal has
        a positive s: pass 3's back faces), or with `away` False towards it (pass 2's front
        faces; edge-on faces neither)."""
        if len(which) == 0:
            return False
        # The winding's normal in local space, along the camera's s (a positive multiple of
        # the posed normal's s: the pose is a rotation times a scale, mirrored by `_handed`).
        s = self._mesh.face_normals().take(which, axis=0) @ (self._local_axes[2] * self._handed)
        return bool((s > 0.0).any() if away else (s < 0.0).any())

    def spheres(self, which: Indices) -> tuple[Array, Array]:
        """Camera-space bounding spheres (centres (k, 3), radii (k,)) of triangles `which`."""
        centre, radius = self._mesh.triangle_spheres()
        return self._to_camera(centre.take(which, axis=0)), radius.take(which) * self._scale

    def s_range(self) -> tuple[float, float]:
        """Bounds of s over the whole mesh (from the cluster spheres, or a built-in shape's
        solid; computed once)."""
        if self._s_range is None:
            if self._segment is not None:
                s = self._segment[:, 2].tolist()
                self._s_range = min(s) - self._radius, max(s) + self._radius
            elif self._faces is not None:
                s = self._faces[..., 2]
                self._s_range = float(s.min()), float(s.max())
            else:
                centre, radius, _ = self._clusters
                c = centre[:, 2]
                self._s_range = float((c - radius).min()), float((c + radius).max())
        return self._s_range

    def rect(self) -> Rect:
        """Bounds of x, y over the whole mesh (from the cluster spheres, or a built-in shape's
        solid; computed once)."""
        if self._rect is None:
            if self._segment is not None:
                (xa, ya, _), (xb, yb, _) = self._segment.tolist()
                r = self._radius
                self._rect = Rect(
                    min(xa, xb) - r, max(xa, xb) + r, min(ya, yb) - r, max(ya, yb) + r
                )
            elif self._faces is not None:
                x, y = self._faces[..., 0], self._faces[..., 1]
                self._rect = Rect(float(x.min()), float(x.max()), float(y.min()), float(y.max()))
            else:
                self._rect = _sphere_rect(*self._clusters[:2])
        return self._rect

    def meeting(self, rect: Rect, slab: tuple[float, float]) -> Indices:
        """Triangles whose bounding sphere meets `rect` and the s range `slab`."""
        return meeting_many([(self, rect, slab)])[0]

    def s_extreme(self, rect: Rect, lowest: bool) -> float | None:
        """The exact lowest (or highest) s of the triangles whose spheres meet `rect`; for a
        built-in shape, of its solid (lower, or higher: conservative)."""
        if self._segment is not None:
            s = self._segment[:, 2]
            return float(s.min() - self._radius) if lowest else float(s.max() + self._radius)
        if self._faces is not None:
            return _faces_extreme(self._faces_towards(lowest), rect, lowest)
        centre, r, all_members = self._clusters
        c = centre[:, 2]
        groups = _meets(centre, r, rect)
        if not groups.any():
            return None
        # Only groups (then triangles) whose sphere may hold the extreme need the exact test.
        if lowest:
            groups &= c - r <= (c + r)[groups].min()
        else:
            groups &= c + r >= (c - r)[groups].max()
        members = all_members[groups].ravel()
        which = members[members >= 0]
        centre, radius = self.spheres(which)
        which = which[_meets(centre, radius, rect)]
        if len(which) == 0:
            return None
        s = self.corners(which)[..., 2]
        return float(s.min()) if lowest else float(s.max())

    def _faces_towards(self, front: bool) -> Array:
        """A built-in shape's faces that may hold its lowest s (`front`: those turned towards the
        camera or edge-on) or its highest (turned away or edge-on): for a closed convex solid
        the view line through any x, y meets a front face before (and a back face after) any
        other point, so the others hold no extreme; an open shape keeps all of its faces."""
        faces, bound = self._faces, self._mesh.bound
        assert faces is not None and bound is not None and bound.outward is not None
        if not self.solid:
            return faces
        # The outward normal's s (a positive multiple): the local one along the camera's s.
        # Unlike `faces_away`, not turned over by a mirroring pose: a mirror moves the solid,
        # not which side is out.
        a0, a1, a2 = self._local_axes[2].tolist()
        s = np.array([a0 * x + a1 * y + a2 * z for x, y, z in bound.outward.tolist()])
        return faces[s <= 0.0] if front else faces[s >= 0.0]

    def slab_part(self, rect: Rect, lo: float, hi: float) -> Rect | None:
        """The x, y extent of the parts with lo <= s <= hi of the triangles meeting `rect` (of
        the solid, for a built-in shape)."""
        if self._segment is not None:
            return swept_sphere_slab(self._segment, self._radius, lo, hi)
        if self._faces is not None:
            return _faces_slab_rect(self._faces.tolist(), lo, hi)
        which = self.meeting(rect, (lo, hi))
        if len(which) == 0:
            return None
        return slab_rect(self.corners(which), lo, hi)


#: One triangle-list query of a batch: a posed mesh, the camera rectangle and the s range whose
#: box the triangles' bounding spheres must meet (`meeting_many`).
Query = tuple[Projected, Rect, tuple[float, float]]


def meeting_many(queries: Sequence[Query], exact: bool = True) -> list[Indices]:
    """`Projected.meeting(rect, slab)` of each query (with `exact` False, the triangles of every
    cluster whose sphere meets the box: a superset, for a GPU that clips and culls faster than
    the CPU can sort), the box tests of a batch's queries of one mesh made together: the
    cluster spheres of every query (queries x clusters), then the triangle spheres of every
    (query, cluster) pair that passes, are put in their query's camera coordinates and tested
    against its box, each step one array operation over all of them. A query's result does
    not depend on the others (each row is posed and tested by its own query's values, element
    by element)."""
    found: list[Indices] = [np.zeros(0, dtype=np.int64)] * len(queries)
    groups: dict[int, list[int]] = {}
    for k, query in enumerate(queries):
        groups.setdefault(id(query[0]._mesh), []).append(k)
    for members in groups.values():
        chosen = [queries[k] for k in members]
        for k, listed in zip(members, _meeting_one_mesh(chosen, exact), strict=True):
            found[k] = listed
    return found


#: Meshes of at most so many triangles have their exact lists found without clusters: a plate's
#: few triangles cost less to test than the steps of a cluster search.
DIRECT_TRIANGLES = 256


def _meeting_one_mesh(queries: Sequence[Query], exact: bool) -> list[Indices]:
    """`meeting_many` of queries on one mesh."""
    mesh = queries[0][0]._mesh
    centre, radius, members = mesh.clusters()
    tris = [q[0] for q in queries]
    axes = np.array([p._local_axes for p in tris])
    offset = np.array([p._offset for p in tris])
    scale = np.array([p._scale for p in tris])
    boxes = np.array([(r.x0, r.x1, r.y0, r.y1, lo, hi) for _, r, (lo, hi) in queries])
    if exact and len(mesh.indices) <= DIRECT_TRIANGLES:
        # Few triangles: every query's triangle spheres at once, no cluster test first.
        spheres, radii = mesh.triangle_spheres()
        posed = _to_cameras(axes[:, None], offset[:, None], spheres[None])
        query, listed = np.nonzero(
            _meets_box(posed, radii[None, :] * scale[:, None], boxes[:, None])
        )
        ends = np.searchsorted(query, np.arange(len(queries) + 1))
        return [listed[ends[k] : ends[k + 1]] for k in range(len(queries))]
    # Every query's cluster spheres (queries x clusters), posed and tested at once.
    posed = _to_cameras(axes[:, None], offset[:, None], centre[None])
    near = _meets_box(posed, radius[None, :] * scale[:, None], boxes[:, None])
    query, cluster = np.nonzero(near)  # by query, then cluster: each query's in order
    if exact:
        # The triangle spheres of the (query, cluster) pairs that pass, whole rows (padding is
        # NaN: never meets).
        local, radii = mesh.cluster_members_spheres()
        posed = _to_cameras(axes[query, None], offset[query, None], local[cluster])
        keep = _meets_box(posed, radii[cluster] * scale[query, None], boxes[query, None])
    else:
        keep = members[cluster] >= 0
    listed = members[cluster][keep]
    rows = np.broadcast_to(query[:, None], keep.shape)[keep]
    ends = np.searchsorted(rows, np.arange(len(queries) + 1))
    return [listed[ends[k] : ends[k + 1]] for k in range(len(queries))]


def _to_cameras(axes: Array, offset: Array, local: Array) -> Array:
    """Camera coordinates of local points (..., 3) by poses (`Poses`: axes (..., 3, 3), offset
    (..., 3), broadcast): each coordinate the sum of three products in order, then the offset
    (a row's bits do not depend on the others). The three products are added as slices: the
    same bits as a sum over the last axis, which numpy reduces slowly at length 3."""
    products = axes * local[..., None, :]
    return (products[..., 0] + products[..., 1]) + products[..., 2] + offset


def _meets_box(centre: Array, radius: Array, box: Array) -> NDArray[np.bool_]:
    """Whether each sphere (centres (..., 3), radii (...)) meets its box (..., 6: x0, x1, y0,
    y1, s0, s1, broadcast); NaN never meets."""
    r = radius[..., None]
    meets = (centre + r >= box[..., 0::2]) & (centre - r <= box[..., 1::2])
    return np.asarray(meets.all(axis=-1))


def lists_many(queries: Sequence[Query], exact: bool = True) -> list[Indices]:
    """`meeting_many` of each query, those on a built-in sphere from its cube atlas in closed
    form (`cube_lists`: no cluster search; with `exact` the same triangles, else the
    triangles of the cells its box projects into, a superset as whole clusters are), the
    others by `meeting_many`; each query's list is the same alone as in any batch."""
    found: list[Indices | None] = [None] * len(queries)
    spheres: dict[int, list[int]] = {}
    rest: list[int] = []
    for k, query in enumerate(queries):
        mesh = query[0]._mesh
        if closed_form(mesh):
            spheres.setdefault(id(mesh), []).append(k)
        else:
            rest.append(k)
    for members in spheres.values():
        for k, listed in zip(
            members, cube_lists([queries[k] for k in members], exact), strict=True
        ):
            found[k] = listed
    for k, listed in zip(rest, meeting_many([queries[k] for k in rest], exact), strict=True):
        found[k] = listed
    return found  # type: ignore[return-value]


def _faces_extreme(faces: Array, rect: Rect, lowest: bool) -> float | None:
    """Lowest (highest) s of the parts of a few faces (k, 3, 3) whose x, y lie in `rect`."""
    found: list[float] = []
    for face in faces.tolist():
        poly = _clip_to_rect(face, rect)
        if poly:
            s = [p[2] for p in poly]
            found.append(min(s) if lowest else max(s))
    if not found:
        return None
    return min(found) if lowest else max(found)


Point = list[float]


def _clip_to_rect(polygon: list[Point], rect: Rect) -> list[Point]:
    """A convex polygon (its corners' x, y, s) clipped to x0 <= x <= x1, y0 <= y <= y1
    (Sutherland-Hodgman, on Python floats: a face has a handful of corners)."""
    planes = ((0, rect.x0, 1.0), (0, rect.x1, -1.0), (1, rect.y0, 1.0), (1, rect.y1, -1.0))
    points = polygon
    for axis, value, sign in planes:
        out: list[Point] = []
        n = len(points)
        for i, p in enumerate(points):
            q = points[(i + 1) % n]
            dp, dq = sign * (p[axis] - value), sign * (q[axis] - value)
            if dp >= 0:
                out.append(p)
            if (dp >= 0) != (dq >= 0):
                t = dp / (dp - dq)
                out.append(
                    [p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t, p[2] + (q[2] - p[2]) * t]
                )
        points = out
        if not points:
            break
    return points


def swept_sphere_slab(segment: Array, radius: float, lo: float, hi: float) -> Rect | None:
    """A bound of the x, y extent of the part with lo <= s <= hi of a sphere of `radius` swept
    along `segment` (2, 3): exact for a sphere, the disc's radius at the slab's nearest depth
    taken along the whole clipped axis for a capsule."""
    a, b = segment.tolist()  # Python floats: a few scalars (numpy costs more per call)
    ds = b[2] - a[2]
    # The part of the axis within `radius` of the slab (parameters t in [0, 1]).
    if abs(ds) < 1e-15:
        if not (lo - radius <= a[2] <= hi + radius):
            return None
        t0, t1 = 0.0, 1.0
    else:
        t0, t1 = sorted(((lo - radius - a[2]) / ds, (hi + radius - a[2]) / ds))
        t0, t1 = max(t0, 0.0), min(t1, 1.0)
        if t0 > t1:
            return None
    p0 = [x + t0 * (y - x) for x, y in zip(a, b, strict=True)]
    p1 = [x + t1 * (y - x) for x, y in zip(a, b, strict=True)]
    # How far the nearest axis point lies outside the slab along s: the disc there is smallest.
    s_near = min(max(lo, min(p0[2], p1[2])), max(p0[2], p1[2]))
    gap = max(lo - s_near, s_near - hi, 0.0)
    if min(p0[2], p1[2]) <= hi and max(p0[2], p1[2]) >= lo:
        gap = 0.0
    reach = math.sqrt(max(radius * radius - gap * gap, 0.0))
    return Rect(
        min(p0[0], p1[0]) - reach,
        max(p0[0], p1[0]) + reach,
        min(p0[1], p1[1]) - reach,
        max(p0[1], p1[1]) + reach,
    )


def _sphere_rect(centre: Array, radius: Array) -> Rect:
    return Rect(
        float((centre[:, 0] - radius).min()),
        float((centre[:, 0] + radius).max()),
        float((centre[:, 1] - radius).min()),
        float((centre[:, 1] + radius).max()),
    )


def _meets(centre: Array, radius: Array, rect: Rect) -> NDArray[np.bool_]:
    """Whether each sphere meets `rect` in x, y (any s)."""
    return (
        (centre[:, 0] + radius >= rect.x0)
        & (centre[:, 0] - radius <= rect.x1)
        & (centre[:, 1] + radius >= rect.y0)
        & (centre[:, 1] - radius <= rect.y1)
    )


def _faces_slab_rect(faces: list[list[Point]], lo: float, hi: float) -> Rect | None:
    """`slab_rect` of a built-in shape's few faces, on Python floats: the same points (the
    corners of faces inside the slab; of faces it cuts, their corners inside it and their
    edges' crossings of its planes), so the same extent."""
    xs: list[float] = []
    ys: list[float] = []
    for tri in faces:
        s = [p[2] for p in tri]
        s_min, s_max = min(s), max(s)
        if s_max < lo or s_min > hi:
            continue
        if s_min >= lo and s_max <= hi:
            xs += [p[0] for p in tri]
            ys += [p[1] for p in tri]
            continue
        for p in tri:
            if lo <= p[2] <= hi:
                xs.append(p[0])
                ys.append(p[1])
        for i, j in ((0, 1), (1, 2), (2, 0)):
            a, b = tri[i], tri[j]
            span = b[2] - a[2]
            if abs(span) <= 1e-300:
                continue
            for plane in (lo, hi):
                f = (plane - a[2]) / span
                if 0.0 <= f <= 1.0:
                    xs.append(a[0] + f * (b[0] - a[0]))
                    ys.append(a[1] + f * (b[1] - a[1]))
    if not xs:
        return None
    return Rect(min(xs), max(xs), min(ys), max(ys))


def slab_rect(tris: Array, lo: float, hi: float) -> Rect | None:
    """The x, y extent of the parts of the triangles (k, 3, 3) with lo <= s <= hi (None: none)."""
    s = tris[..., 2]
    s_min, s_max = s.min(1), s.max(1)
    whole = tris[(s_min >= lo) & (s_max <= hi)]  # inside the slab: their corners are the extent
    cut = tris[(s_max >= lo) & (s_min <= hi) & ((s_min < lo) | (s_max > hi))]
    xs: list[Array] = [whole[..., 0].ravel()]
    ys: list[Array] = [whole[..., 1].ravel()]
    if len(cut):
        s = cut[..., 2]
        inside = (s >= lo) & (s <= hi)
        xs.append(cut[..., 0][inside])
        ys.append(cut[..., 1][inside])
        for i, j in ((0, 1), (1, 2), (2, 0)):
            a, b = cut[:, i], cut[:, j]
            span = b[:, 2] - a[:, 2]
            flat = np.abs(span) <= 1e-300
            safe = np.where(flat, 1.0, span)
            for plane in (lo, hi):
                f = (plane - a[:, 2]) / safe
                crossing = ~flat & (f >= 0.0) & (f <= 1.0)
                point = a[crossing] + f[crossing, None] * (b[crossing] - a[crossing])
                xs.append(point[:, 0])
                ys.append(point[:, 1])
    x, y = np.concatenate(xs), np.concatenate(ys)
    if len(x) == 0:
        return None
    return Rect(float(x.min()), float(x.max()), float(y.min()), float(y.max()))


def overlap(
    target: Projected,
    tool: Projected,
    target_max_height: float = 0.0,
    tool_max_height: float = 0.0,
    advance: float = 0.0,
) -> Overlap | None:
    """The bound of the overlap of `target` and the advanced `tool`. `*_max_height` is the highest
    height each map holds (metres; > 0: bumps that stand proud of the mesh); `advance` how far
    the tool was moved from first touch (metres along s). None: they cannot meet."""
    near_tool, near_target = tool.rect(), target.rect()
    s_lo = target.s_extreme(near_tool, lowest=True)  # the target's nearest point: first touch
    s_hi = tool.s_extreme(near_target, lowest=False)  # how far the advanced tool reaches
    if s_lo is None or s_hi is None:
        return None
    bumps = max(target_max_height, 0.0) + max(tool_max_height, 0.0)
    # No target point nearer than a solid tool's nearest point at first touch can lie inside the
    # solid it sweeps: a concave target's surfaces behind the tool (a shelf over it, the far wall
    # of a ring around it) stay out of the slab, whatever the target's nearest point is. An open
    # tool (a plate) has no nearest point of its solid.
    tool_lo = tool.s_extreme(near_target, lowest=True) if tool.solid else None
    if tool_lo is not None:
        s_lo = max(s_lo, tool_lo - advance - bumps)
    if s_hi + bumps < s_lo:
        return None
    # A target point can move if its bumped point lies inside the bumped tool; a tool point can
    # reach if its bumped point lies beyond the target's bumped surface.
    target_rect = target.slab_part(near_tool, s_lo, s_hi + bumps)
    tool_rect = tool.slab_part(near_target, s_lo - bumps, s_hi)
    if target_rect is None or tool_rect is None:
        return None
    rect = target_rect.intersect(tool_rect)
    # Extents that only touch (a tool sliding along the surface, or moving off it) hold no
    # overlap: TOUCH_METRES allows for the rounding of a tangent solid's extent.
    if rect is None or min(rect.x1 - rect.x0, rect.y1 - rect.y0) <= TOUCH_METRES:
        return None
    return Overlap(rect, (s_lo, s_hi + bumps))
