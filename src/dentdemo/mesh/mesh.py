"""The Mesh type: positions, normals, right-handed tangent frames, unique UVs; local metres."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from dentdemo.errors import ArgumentError
from dentdemo.mesh.cube import cube_atlas_indices, cube_triangle

F32 = NDArray[np.float32]
#: Triangles per cluster of `Mesh.clusters`.
CLUSTER_SIZE = 32
#: Triangles whose frames `Mesh.frame_near` keeps (cleared when full).
FRAMES_KEPT = 4096


@dataclass(frozen=True)
class SurfacePoint:
    """A point on a mesh surface with its local frame (all in the mesh's local space)."""

    uv: NDArray[np.float64]
    #: Partial derivatives of position by u and v, m per uv unit.
    dpdu: NDArray[np.float64]
    dpdv: NDArray[np.float64]
    normal: NDArray[np.float64]
    distance: float


@dataclass(frozen=True)
class Bound:
    """A simple solid that holds a built-in mesh (local metres), for exact footprint bounds at
    the cost of a formula: a sphere swept along a segment (sphere: both ends at the centre;
    capsule and cylinder: the axis), or a few triangles that are the mesh's own faces (box,
    plate)."""

    segment: NDArray[np.float64] | None = None  # (2, 3)
    radius: float = 0.0
    triangles: NDArray[np.float64] | None = None  # (k, 3, 3)
    #: True when the swept sphere is the shape's own surface (sphere, capsule), which the carve
    #: then uses instead of the facets; False where it only holds it (cylinder).
    exact: bool = False
    #: A built-in capsule's profile rows per hemisphere (its atlas's v follows them: the
    #: carve's capsule_uv.glsl), 0 for any other shape.
    rings: int = 0
    #: A built-in sphere's cells per cube-face edge (its atlas: each face an n x n grid in its cell
    #: of the 3 x 2 atlas; the carve's texel rectangles, cube_grid.glsl), 0 for any other shape.
    grid: int = 0
    #: An open shape's material behind its faces, metres (a plate's thickness under its top face:
    #: mesh/thickness.py bounds dents by it; 0: none known, the ground).
    depth: float = 0.0

    @cached_property
    def outward(self) -> NDArray[np.float64] | None:
        """(k, 3) an outward normal of each of `triangles` (not unit: the cross product of its
        edges, counter-clockwise seen from outside), or None without them."""
        t = self.triangles
        if t is None:
            return None
        return np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])

    @cached_property
    def quad(self) -> int:
        """How the carve's camera passes may draw the shape as one quad, intersecting its solid
        per pixel: 1 a sphere (both ends of its segment one point), 2 a capsule (its atlas's
        profile rows known), 0 neither (a shape the swept sphere only holds, or no sphere)."""
        if not self.exact or self.segment is None:
            return 0
        if np.array_equal(self.segment[0], self.segment[1]):
            return 1
        return 2 if self.rings > 0 else 0


@dataclass
class Mesh:
    """An indexed triangle mesh in local metres; faces wind counter-clockwise seen from outside.

    `tangents` (n, 4) give each vertex's tangent frame, the one the normal map is expressed in:
    xyz is the unit tangent T along +u (orthogonal to the normal N), w = +1 or -1 the handedness,
    and the bitangent is B = cross(N, T) * w (along +v). A texel's normal m (xyz * 2 - 1 of
    `DentableSurface.normal`) is T m.x + B m.y + N m.z. `source_vertex` (n,) is, for each vertex,
    the index of the caller's vertex it copies (`mesh_from_triangles` splits vertices along
    seams and creases), so that a host can map its own per-vertex data onto this mesh.
    """

    name: str
    positions: F32  # (n, 3) local metres
    normals: F32  # (n, 3) unit, outward
    uvs: F32  # (n, 2) in [0, 1], unique per surface point (an atlas)
    indices: NDArray[np.uint32]  # (m, 3)
    tangents: F32 = field(default=None)  # type: ignore[arg-type]  # made in __post_init__; (n, 4): xyz along +u, w = handedness (+1 right-handed)
    #: The solid that holds the mesh, where it is a built-in shape (None: only its triangles).
    bound: Bound | None = None
    #: The file's own base-colour image, uint8 [rows top-down, cols, RGB(A)] sRGB, or None.
    base_colour_image: NDArray[np.uint8] | None = None
    #: Where that image is sampled: the file's texture coordinates (n, 2), which may tile or
    #: overlap (the carve's atlas is `uvs`). None: `uvs`.
    texture_uvs: F32 | None = None
    #: The caller's vertex each vertex copies (None: vertex i is the caller's i).
    source_vertex: NDArray[np.int64] = field(default=None)  # type: ignore[arg-type]

    def __post_init__(self) -> None:
        _check_arrays(self)
        self.positions = np.ascontiguousarray(self.positions, dtype=np.float32)
        self.normals = np.ascontiguousarray(self.normals, dtype=np.float32)
        self.uvs = np.ascontiguousarray(self.uvs, dtype=np.float32)
        if self.texture_uvs is not None:
            self.texture_uvs = np.ascontiguousarray(self.texture_uvs, dtype=np.float32)
        self.indices = np.ascontiguousarray(self.indices, dtype=np.uint32).reshape(-1, 3)
        if self.source_vertex is None:
            self.source_vertex = np.arange(len(self.positions), dtype=np.int64)
        self.source_vertex = np.ascontiguousarray(self.source_vertex, dtype=np.int64)
        self._drop_degenerate()
        self._orient_outward()
        if self.tangents is None:
            self.tangents = compute_tangents(self.positions, self.normals, self.uvs, self.indices)

    # -- geometry queries ---------------------------------------------------------------------
    @property
    def bounding_radius(self) -> float:
        """Radius of the sphere about the local origin that holds the mesh, m."""
        return float(np.sqrt((self.positions.astype(np.float64) ** 2).sum(axis=1).max()))

    def triangle_corners(self) -> tuple[NDArray[np.float64], ...]:
        p = self.positions.astype(np.float64)
        i = self.indices
        return p[i[:, 0]], p[i[:, 1]], p[i[:, 2]]

    def corner_array(self) -> NDArray[np.float64]:
        """(m, 3, 3) float64 triangle corners, local metres (cached)."""
        a, b, c = self._bounds()[:3]
        cached = getattr(self, "_corner_cache", None)
        if cached is None or cached.shape[0] != len(a):
            cached = np.stack([a, b, c], axis=1)
            self._corner_cache = cached
        return cached

    def triangle_spheres(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Each triangle's bounding sphere: centres (m, 3) and radii (m,), local metres (cached)."""
        _, _, _, centre, radius = self._bounds()
        return centre, radius

    def triangle_reach(self) -> float:
        """The largest triangle bounding-sphere radius, local metres (cached)."""
        cached = getattr(self, "_reach_cache", None)
        if cached is None or cached[0] != len(self.indices):
            cached = (len(self.indices), float(self.triangle_spheres()[1].max(initial=0.0)))
            self._reach_cache = cached
        return cached[1]

    def triangle_derivatives(
        self, which: NDArray[np.int64] | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """dP/du and dP/dv of triangles `which` (all: None), local metres per uv unit (cached
        for the whole mesh: a hit asks for one triangle's)."""
        cached = getattr(self, "_derivative_cache", None)
        if cached is None or len(cached[0]) != len(self.indices):
            dpdu, dpdv, _ = _triangle_derivatives(self)
            cached = (dpdu, dpdv)
            self._derivative_cache = cached
        if which is None:
            return cached
        return cached[0][which], cached[1][which]

    def face_normals(self) -> NDArray[np.float64]:
        """(m, 3) each triangle's (b - a) x (c - a), local, not normalised: outward by the
        winding (cached)."""
        cached = getattr(self, "_face_normal_cache", None)
        if cached is None or len(cached) != len(self.indices):
            a, b, c = self._bounds()[:3]
            cached = np.cross(b - a, c - a)
            self._face_normal_cache = cached
        return cached

    def triangle_uv_bounds(self) -> NDArray[np.float64]:
        """(4, m): each triangle's u min, v min, u max, v max as rows, uv units (cached). Rows,
        not columns: a query takes some triangles' columns and reduces each row, which numpy
        does ten times faster on contiguous rows than on the columns of an (m, 4) array."""
        cached = getattr(self, "_uv_bounds_cache", None)
        if cached is None or cached.shape[1] != len(self.indices):
            uv = self.uvs[self.indices].astype(np.float64)  # (m, 3, 2)
            cached = np.ascontiguousarray(np.hstack([uv.min(axis=1), uv.max(axis=1)]).T)
            self._uv_bounds_cache = cached
        return cached

    def facet_sag(self) -> float:
        """How far (local metres) the facets lie inside the smooth solid of an exact `bound` (a
        built-in sphere or capsule, whose vertices lie on it) at most; 0 for any other mesh.
        The carve dents such a body's texels at their points moved onto the solid, but clips
        them at their facet points: its slab grows by this (camera.py). Per triangle: about the
        centre of a sphere or a capsule's end (every corner past that end), the distance of the
        triangle's plane from it; across a capsule's side (every corner between the ends), the
        distance of the nearest point of its cross-section, whose corners lie on the circle, the
        middle of the longest chord; anything else, its longest edge (every point of the
        triangle is within it of a corner). Cached."""
        bound = self.bound
        if bound is None or not bound.exact or bound.segment is None:
            return 0.0
        cached = getattr(self, "_sag_cache", None)
        if cached is not None and cached[0] == len(self.indices):
            return cached[1]
        corners = self.corner_array()
        a, b = (np.asarray(end, dtype=np.float64) for end in bound.segment)
        r = bound.radius
        length = float(np.linalg.norm(b - a))
        edges = corners[:, [1, 2, 0]] - corners
        sag = np.linalg.norm(edges, axis=2).max(axis=1)  # anything else
        normals = self.face_normals()
        unit = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
        eps = 1e-6 * max(r, length)  # the corners are float32
        ends: list[tuple[NDArray[np.bool_], NDArray[np.float64]]]
        if length <= eps:
            ends = [(np.ones(len(corners), dtype=bool), a)]
        else:
            axis = (b - a) / length
            t = (corners - a) @ axis  # (m, 3) along the axis
            ends = [(np.all(t <= eps, axis=1), a), (np.all(t >= length - eps, axis=1), b)]
            side = ((t >= -eps) & (t <= length + eps)).all(axis=1)
            across = edges - (edges @ axis)[..., None] * axis  # chords in the cross-section
            chord = np.linalg.norm(across[side], axis=2).max(axis=1)
            sag[side] = r - np.sqrt(np.maximum(r * r - (chord / 2) ** 2, 0.0))
        for past, centre in ends:
            plane = np.abs(((corners[past, 0] - centre) * unit[past]).sum(axis=1))
            sag[past] = r - plane
        value = float(max(sag.max(initial=0.0), 0.0))
        self._sag_cache = (len(self.indices), value)
        return value

    def shared_normal(self) -> NDArray[np.float32] | None:
        """The normal every vertex has, where they all have the same one (a plate), else None
        (cached)."""
        cached = getattr(self, "_shared_normal_cache", None)
        if cached is None or cached[1] != len(self.normals):
            same = len(self.normals) > 0 and bool((self.normals == self.normals[0]).all())
            cached = (self.normals[0].copy() if same else None, len(self.normals))
            self._shared_normal_cache = cached
        return cached[0]

    def encloses_volume(self) -> bool:
        """Whether the surface is closed (its holes, if any, span at most MAX_OPEN_SHARE of its
        area): then it bounds a solid, and its faces seen from outside are its front faces. A
        plate or a bowl does not. Cached."""
        cached = getattr(self, "_encloses_cache", None)
        if cached is None:
            from dentdemo.model.shapes import MAX_OPEN_SHARE, mesh_volume

            cached = mesh_volume(self.positions, self.indices)[1] <= MAX_OPEN_SHARE
            self._encloses_cache = cached
        return bool(cached)

    def chart_border(self) -> NDArray[np.bool_]:
        """(m,) True for triangles with an edge on a UV chart's border (an edge no other triangle
        shares: seams split vertices, so seams count). Only these touch gutter texels. Cached."""
        cached = getattr(self, "_border_cache", None)
        if cached is not None and len(cached) == len(self.indices):
            return cached
        cached = np.asarray(self._lone_edges().reshape(3, -1).any(axis=0))  # any of its three
        self._border_cache = cached
        return cached

    def _lone_edges(self) -> NDArray[np.bool_]:
        """(3 m,) whether each edge (e m + t: edge e of triangle t, as `_sorted_edges` numbers
        them) is one no other triangle shares: on a chart's border."""
        order, same = self._sorted_edges()
        alone = ~(np.concatenate([[False], same]) | np.concatenate([same, [False]]))
        lone = np.empty(len(order), dtype=bool)
        lone[order] = alone
        return lone

    def charts_fill_map(self) -> bool:
        """Whether the UV triangles tile the whole unit square (a plate's one chart): each lies
        in it and turns the same way, they cover an area of exactly 1 and every chart-border
        edge (`chart_border`) lies on a side of the square. Then every point inside the square
        lies in exactly one triangle, so every texel centre of a map lies in a chart and the map
        has no gutter texel: the carve draws no gutter there (passes 4 and 5 would discard
        every texel of it). Cached."""
        cached = getattr(self, "_fills_cache", None)
        if cached is not None and cached[0] == len(self.indices):
            return cached[1]
        uv = self.uvs.astype(np.float64)
        t = uv[self.indices]  # (m, 3, 2)
        e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        signed = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
        inside = bool(((t >= 0.0) & (t <= 1.0)).all())
        one_way = bool((signed > 0.0).all() or (signed < 0.0).all())
        fills = inside and one_way and abs(abs(float(signed.sum())) - 1.0) <= 1e-9
        if fills:
            lone = self._lone_edges()
            a = uv[self.indices.T.ravel()[lone]]  # edge e of triangle t runs from its corner e
            b = uv[self.indices[:, [1, 2, 0]].T.ravel()[lone]]  # to its corner e + 1
            on_side = ((a == b) & ((a == 0.0) | (a == 1.0))).any(axis=1)  # u or v fixed at 0 or 1
            fills = bool(on_side.all())
        self._fills_cache = (len(self.indices), fills)
        return fills

    def _sorted_edges(self) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
        """The triangles' edges sorted by their two vertices (stably; edge e of triangle t is
        number e m + t: edges 0-1 of every triangle, then 1-2, then 2-0), and for each sorted
        edge but the last whether the next is the same edge (shared by two triangles). Cached:
        chart_border and triangle_charts both read it."""
        cached = getattr(self, "_edge_cache", None)
        if cached is not None and cached[0] == len(self.indices):
            return cached[1], cached[2]
        tri = self.indices.astype(np.int64)
        a = np.concatenate([tri[:, 0], tri[:, 1], tri[:, 2]])
        b = np.concatenate([tri[:, 1], tri[:, 2], tri[:, 0]])
        key = np.minimum(a, b) * len(self.positions) + np.maximum(a, b)  # one int per edge
        order = np.argsort(key, kind="stable")
        key = key[order]
        same = key[1:] == key[:-1]
        self._edge_cache = (len(self.indices), order, same)
        return order, same

    def triangle_charts(self) -> NDArray[np.int64]:
        """(m,) the UV chart of each triangle: triangles that share an edge (the same two
        vertices: seams split vertices) are in one chart, labelled by its lowest triangle index.
        Cached."""
        cached = getattr(self, "_chart_cache", None)
        if cached is not None and len(cached) == len(self.indices):
            return cached
        order, shared = self._sorted_edges()
        owner = order % len(self.indices)  # the triangle of each sorted edge
        first, second = owner[:-1][shared], owner[1:][shared]  # triangles across an edge
        label = np.arange(len(self.indices))
        while True:  # each triangle takes the lowest label across its edges, then its label's
            low = np.minimum(label[first], label[second])
            new = label.copy()
            np.minimum.at(new, first, low)
            np.minimum.at(new, second, low)
            new = new[new[new]]  # (pointer jumping: a chart's labels meet in a few rounds)
            if np.array_equal(new, label):
                break
            label = new
        self._chart_cache = label
        return label

    def clusters(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
        """Spatially coherent groups of CLUSTER_SIZE triangles (cached): bounding-sphere centres
        (k, 3) and radii (k,), local metres, and members (k, CLUSTER_SIZE) as triangle indices,
        -1 where the last group is short. Queries test groups first, then their triangles."""
        cached = getattr(self, "_cluster_cache", None)
        if cached is not None and cached[3] == len(self.indices):
            return cached[:3]
        centre, radius = self.triangle_spheres()
        order = _morton_order(centre)
        count = -(-len(order) // CLUSTER_SIZE)
        flat = np.full(count * CLUSTER_SIZE, -1, dtype=np.int64)
        flat[: len(order)] = order
        members = flat.reshape(count, CLUSTER_SIZE)
        valid = members >= 0
        safe = np.where(valid, members, members[:, :1])
        group_centre = centre[safe].mean(axis=1)
        reach = np.linalg.norm(centre[safe] - group_centre[:, None], axis=2) + radius[safe]
        group_radius = np.where(valid, reach, 0.0).max(axis=1)
        self._cluster_cache = (group_centre, group_radius, members, len(self.indices))
        return group_centre, group_radius, members

    def prepare_queries(self) -> None:
        """Build now the cached structures pass 1 and the undo log query (corners, bounding
        spheres, clusters, uv derivatives and bounds, chart borders and charts, closedness, the
        facets' sag, how `frame_near` finds its triangle, flatness), as a body is made:
        otherwise each body builds them inside its first hit's carve, and a sandbox drop's hits
        are mostly first hits (docs/performance.md)."""
        self.corner_array()
        self.face_normals()
        self.triangle_uv_bounds()
        self.clusters()
        self.triangle_reach()
        self.cluster_members_spheres()
        self.shared_normal()
        self.triangle_derivatives()
        self.chart_border()
        self.charts_fill_map()
        self.triangle_charts()
        self.encloses_volume()
        self.facet_sag()
        self._frame_lookup()
        self.is_flat()

    def cluster_members_spheres(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The bounding spheres of each cluster's triangles laid out as `clusters()`'s members:
        centres (k, CLUSTER_SIZE, 3) and radii (k, CLUSTER_SIZE), local metres, NaN where a
        cluster is short (cached): a query takes whole rows of them, without gathering."""
        cached = getattr(self, "_member_sphere_cache", None)
        if cached is None or cached[2] != len(self.indices):
            centre, radius = self.triangle_spheres()
            members = self.clusters()[2]
            valid = members >= 0
            safe = np.where(valid, members, 0)
            centres = np.where(valid[..., None], centre[safe], np.nan)
            radii = np.where(valid, radius[safe], np.nan)
            cached = (centres, radii, len(self.indices))
            self._member_sphere_cache = cached
        return cached[0], cached[1]

    def surface_area(self) -> float:
        a, b, c = self.triangle_corners()
        return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())

    def uv_scale(self) -> tuple[float, float]:
        """Area-weighted mean |dP/du| and |dP/dv|: metres per unit of u and of v."""
        dpdu, dpdv, area = _triangle_derivatives(self)
        w = area / max(area.sum(), 1e-30)
        return (
            float((np.linalg.norm(dpdu, axis=1) * w).sum()),
            float((np.linalg.norm(dpdv, axis=1) * w).sum()),
        )

    def _bounds(self) -> tuple[NDArray[np.float64], ...]:
        """Cached float64 corners and each triangle's bounding sphere (centre, radius)."""
        cached = getattr(self, "_bounds_cache", None)
        if cached is None or cached[0].shape[0] != len(self.indices):
            a, b, c = self.triangle_corners()
            centre = (a + b + c) / 3.0
            radius = np.sqrt(np.max([((x - centre) ** 2).sum(1) for x in (a, b, c)], axis=0))
            cached = (a, b, c, centre, radius)
            self._bounds_cache = cached
        return cached

    def surface_at(self, point: NDArray[np.float64]) -> SurfacePoint:
        """The surface point nearest to `point` (local metres), with its uv and tangent frame."""
        p = np.asarray(point, dtype=np.float64)
        a, b, c, centre, radius = self._bounds()
        # Only clusters, then triangles, whose bounding sphere may hold the nearest point get the
        # exact test.
        group_centre, group_radius, members = self.clusters()
        to_group = np.sqrt(((group_centre - p) ** 2).sum(1))
        groups = to_group - group_radius <= (to_group + group_radius).min()
        candidates = members[groups].ravel()
        candidates = candidates[candidates >= 0]
        to_centre = np.sqrt(((centre[candidates] - p) ** 2).sum(1))
        candidates = candidates[
            to_centre - radius[candidates] <= (to_centre + radius[candidates]).min()
        ]
        closest, bary = _closest_on_triangles(p, a[candidates], b[candidates], c[candidates])
        dist = np.linalg.norm(closest - p, axis=1)
        best = int(np.argmin(dist))
        k = int(candidates[best])
        bary, dist = bary[best : best + 1], dist[best : best + 1]
        a, b, c = a[k : k + 1], b[k : k + 1], c[k : k + 1]
        uv = (self.uvs.astype(np.float64)[self.indices[k]] * bary[0][:, None]).sum(axis=0)
        dpdu, dpdv = self.triangle_derivatives(np.array([k]))
        n = np.cross(b[0] - a[0], c[0] - a[0])
        n /= max(np.linalg.norm(n), 1e-30)
        return SurfacePoint(uv, dpdu[0], dpdv[0], n, float(dist[0]))

    def frame_near(self, point: NDArray[np.float64]) -> SurfacePoint:
        """The uv and tangent frame of a triangle near `point` (local metres), with uv extended
        affinely to the point's projection on its plane: a cheap frame for orienting and sizing
        a view (exact uv on a flat chart); `surface_at` gives the exact nearest point. The
        triangle is found without a search where the mesh says where it is (`_frame_lookup`):
        any one of a flat mesh with one affine uv map (a plate), the one under the point's
        direction in its cube cell of a built-in sphere; elsewhere it is the triangle whose
        bounding-sphere centre is nearest."""
        p = np.asarray(point, dtype=np.float64)
        lookup = self._frame_lookup()
        if lookup == "flat":
            k = 0  # one plane and one affine uv map: every triangle gives the same frame
        elif lookup == "cube":
            x, y, z = p.tolist()
            k = cube_triangle((x, y, z), self.bound.grid)  # type: ignore[union-attr]
        else:
            group_centre, group_radius, members = self.clusters()
            d = group_centre - p
            to_group = np.sqrt(np.einsum("ij,ij->i", d, d))
            group = members[int(np.argmin(to_group - group_radius))]
            group = group[group >= 0]
            centre, _ = self.triangle_spheres()
            d = centre[group] - p
            k = int(group[np.argmin(np.einsum("ij,ij->i", d, d))])
        (ux, uy, uz), (vx, vy, vz), (nx, ny, nz), (ax, ay, az), (u0, v0), g, normal = (
            self._triangle_frame(k)
        )
        guu, guv, gvv, det = g
        px, py, pz = p.tolist()
        rx, ry, rz = px - ax, py - ay, pz - az
        distance = abs(rx * nx + ry * ny + rz * nz)
        # uv offset of p's projection on the plane: solve rel = s dpdu + t dpdv (normal
        # equations of the 3 x 2 system).
        bu, bv = rx * ux + ry * uy + rz * uz, rx * vx + ry * vy + rz * vz
        dpdu, dpdv = self.triangle_derivatives()
        return SurfacePoint(
            np.array([u0 + (gvv * bu - guv * bv) / det, v0 + (guu * bv - guv * bu) / det]),
            dpdu[k],
            dpdv[k],
            normal.copy(),
            distance,
        )

    def _triangle_frame(self, k: int) -> tuple:
        """What `frame_near` takes of triangle k, whatever the point (cached by triangle, at
        most FRAMES_KEPT: a burst's hits come back to a few): dP/du, dP/dv, the unit normal,
        the first corner and its uv on Python floats, the normal equations' (guu, guv, gvv,
        det), and the normal turned outwards (by the corner's vertex normal) as an array."""
        cached: tuple[int, dict[int, tuple]] | None = getattr(self, "_triangle_frame_cache", None)
        if cached is None or cached[0] != len(self.indices):
            cached = (len(self.indices), {})
            self._triangle_frame_cache = cached
        frame = cached[1].get(k)
        if frame is None:
            if len(cached[1]) >= FRAMES_KEPT:
                cached[1].clear()
            dpdu, dpdv = self.triangle_derivatives()
            corner = int(self.indices[k, 0])
            # One triangle's frame: a few scalars, on Python floats (numpy costs more a call).
            ux, uy, uz = dpdu[k].tolist()
            vx, vy, vz = dpdv[k].tolist()
            nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            length = max(math.sqrt(nx * nx + ny * ny + nz * nz), 1e-30)
            nx, ny, nz = nx / length, ny / length, nz / length
            guu = ux * ux + uy * uy + uz * uz
            guv = ux * vx + uy * vy + uz * vz
            gvv = vx * vx + vy * vy + vz * vz
            det = guu * gvv - guv * guv
            det = det if det else 1e-30
            wx, wy, wz = self.normals[corner].tolist()
            outward = 1.0 if nx * wx + ny * wy + nz * wz >= 0 else -1.0
            frame = (
                (ux, uy, uz),
                (vx, vy, vz),
                (nx, ny, nz),
                tuple(self.positions[corner].tolist()),
                tuple(self.uvs[corner].tolist()),
                (guu, guv, gvv, det),
                np.array([nx * outward, ny * outward, nz * outward]),
            )
            cached[1][k] = frame
        return frame

    def is_flat(self) -> bool:
        """Whether every triangle has one plane and one affine uv map (a plate), to float32's
        rounding of positions and uvs: normals equal, uv derivatives within 1e-6 of their size
        (cached)."""
        cached = getattr(self, "_flat_cache", None)
        if cached is None or cached[0] != len(self.indices):
            cached = (len(self.indices), self._one_affine_map(1e-6))
            self._flat_cache = cached
        return cached[1]

    def _one_affine_map(self, tolerance: float) -> bool:
        """One plane (every normal the same) and uv derivatives within `tolerance` of their
        size of the first triangle's."""
        dpdu, dpdv = self.triangle_derivatives()
        return self.shared_normal() is not None and all(
            np.abs(d - d[0]).max() <= tolerance * max(float(np.abs(d[0]).max()), 1e-30)
            for d in (dpdu, dpdv)
        )

    def laid_as_cube_sphere(self) -> bool:
        """Whether this is a built-in sphere whose triangles are still those its cube atlas laid
        out (`cube.cube_triangle` and the carve's `cube_lists` find them in closed form)."""
        return self._frame_lookup() == "cube"

    def _frame_lookup(self) -> str:
        """How `frame_near` finds its triangle (cached): "flat" where every triangle has one
        plane and one affine uv map (their normals and uv derivatives agree to 1e-9 of their
        size: closer than `is_flat`, as a plate's camera placed from another triangle's frame
        moves by their rounding, which moved one texel's rebuilt normal by 1/255 in a test),
        "cube" for a built-in sphere whose triangles are still those `primitives.sphere` laid
        out (`cube.cube_triangle` finds them), else "search"."""
        cached = getattr(self, "_frame_lookup_cache", None)
        if cached is not None and cached[0] == len(self.indices):
            return cached[1]
        way = "search"
        if self._one_affine_map(1e-9):
            way = "flat"
        elif self.bound is not None and self.bound.quad == 1 and self.bound.grid > 0:
            laid = cube_atlas_indices(self.bound.grid)
            if laid.shape == self.indices.shape and np.array_equal(
                np.sort(laid, axis=1), np.sort(self.indices.astype(np.int64), axis=1)
            ):
                way = "cube"
        self._frame_lookup_cache = (len(self.indices), way)
        return way

    # -- clean-up ------------------------------------------------------------------------------
    def _drop_degenerate(self) -> None:
        space, atlas = doubled_areas(self.positions, self.uvs, self.indices)
        keep = (space > DEGENERATE) & (atlas > DEGENERATE)
        self.indices = np.ascontiguousarray(self.indices[keep])

    def _orient_outward(self) -> None:
        a, b, c = self.triangle_corners()
        face_n = np.cross(b - a, c - a)
        vert_n = self.normals.astype(np.float64)[self.indices].sum(axis=1)
        flip = (face_n * vert_n).sum(axis=1) < 0
        self.indices[flip] = self.indices[flip][:, ::-1]


#: A triangle whose doubled area (m^2 in space, uv units^2 in the atlas) is at most this has
#: none there: Mesh drops it (no texel of the maps would be its own).
DEGENERATE = 1e-14


def doubled_areas(
    positions: NDArray[np.floating], uvs: NDArray[np.floating], indices: NDArray[np.integer]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each triangle's doubled area in space and in the atlas, from float32 values (what Mesh
    holds) computed in float64."""
    p = np.asarray(positions, np.float32).astype(np.float64)[indices]
    t = np.asarray(uvs, np.float32).astype(np.float64)[indices]
    space = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    return space, np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


def _check_arrays(mesh: Mesh) -> None:
    """One clear error for arrays of the wrong shape, non-finite values or indices out of range."""

    def array(name: str, columns: int) -> NDArray:
        value = getattr(mesh, name)
        try:
            data = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            data = np.zeros((0, 0))
        if data.ndim != 2 or data.shape[1] != columns or not np.isfinite(data).all():
            shown = getattr(value, "shape", None) or type(value).__name__
            raise ArgumentError(
                f"Mesh {name} must be an (n, {columns}) array of finite numbers, got {shown}"
            )
        return data

    n = len(array("positions", 3))
    optional = [("texture_uvs", 2), ("tangents", 4)]
    for name, columns in [("normals", 3), ("uvs", 2), *optional]:
        if getattr(mesh, name) is None and (name, columns) in optional:
            continue
        if len(array(name, columns)) != n:
            raise ArgumentError(
                f"Mesh {name} must have one row per position ({n}), got {len(getattr(mesh, name))}"
            )
    check_indices("Mesh indices", mesh.indices, n)


def check_indices(what: str, indices: object, vertices: int) -> NDArray[np.int64]:
    """`indices` as an (m, 3) int64 array of vertex numbers below `vertices`, or an error
    naming `what` and the offending value."""
    data = np.asarray(indices)
    if data.size == 0 or data.dtype.kind not in "iu" or data.size % 3 or data.ndim > 2:
        raise ArgumentError(
            f"{what} must be (m, 3) integers, got {data.dtype} of shape {data.shape}"
        )
    out = data.astype(np.int64).reshape(-1, 3)
    if out.min() < 0 or out.max() >= vertices:
        bad = int(out.min()) if out.min() < 0 else int(out.max())
        raise ArgumentError(f"{what} must lie in [0, {vertices - 1}], got {bad}")
    return out


def _morton_order(points: NDArray[np.float64]) -> NDArray[np.int64]:
    """Indices that sort points along a Z-order (Morton) curve of 10 bits per axis."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    cells = ((points - lo) / np.maximum(hi - lo, 1e-30) * 1023).astype(np.int64)
    code = np.zeros(len(points), dtype=np.int64)
    for bit in range(10):
        for axis in range(3):
            code |= ((cells[:, axis] >> bit) & 1) << (3 * bit + axis)
    return np.argsort(code, kind="stable")


def _triangle_derivatives(
    mesh: Mesh, which: NDArray[np.int64] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Per-triangle dP/du, dP/dv (m per uv unit) and area (m^2)."""
    idx = mesh.indices if which is None else mesh.indices[which]
    p = mesh.positions[idx].astype(np.float64)  # index first: a hit asks for one triangle
    t = mesh.uvs[idx].astype(np.float64)
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    det = np.where(np.abs(det) < 1e-20, 1e-20, det)
    dpdu = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) / det[:, None]
    dpdv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) / det[:, None]
    area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
    return dpdu, dpdv, area


def compute_tangents(positions: F32, normals: F32, uvs: F32, indices: NDArray[np.uint32]) -> F32:
    """Per-vertex tangent along +u, Gram-Schmidt against the normal; w = +1 where (T, B, N) is
    right-handed with B along +v, -1 where the uv map is mirrored."""
    mesh_like = Mesh.__new__(Mesh)
    mesh_like.positions, mesh_like.uvs, mesh_like.indices = positions, uvs, indices
    dpdu, dpdv, area = _triangle_derivatives(mesh_like)
    n = len(positions)
    tan = np.zeros((n, 3))
    bit = np.zeros((n, 3))
    for corner in range(3):
        np.add.at(tan, indices[:, corner], dpdu * area[:, None])
        np.add.at(bit, indices[:, corner], dpdv * area[:, None])
    nrm = normals.astype(np.float64)
    tan -= nrm * (tan * nrm).sum(axis=1, keepdims=True)
    length = np.linalg.norm(tan, axis=1, keepdims=True)
    # Fallback where +u is undefined (poles): any unit vector orthogonal to the normal.
    fallback = np.cross(nrm, np.where(np.abs(nrm[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    tan = np.where(length > 1e-12, tan / np.maximum(length, 1e-30), fallback)
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    handed = np.where((np.cross(nrm, tan) * bit).sum(axis=1) < 0.0, -1.0, 1.0)
    return np.hstack([tan, handed[:, None]]).astype(np.float32)


def _closest_on_triangles(
    p: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64], c: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Closest points on many triangles to one point, with barycentric weights (Ericson 5.1.5)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp = p - b
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    cp = p - c
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    denom = np.where(np.abs(va + vb + vc) < 1e-30, 1e-30, va + vb + vc)
    v = vb / denom
    w = vc / denom
    bary = np.stack([1 - v - w, v, w], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        # Edge and vertex regions.
        regions = [
            ((d1 <= 0) & (d2 <= 0), np.stack([np.ones_like(d1), 0 * d1, 0 * d1], 1)),
            ((d3 >= 0) & (d4 <= d3), np.stack([0 * d1, np.ones_like(d1), 0 * d1], 1)),
            ((d6 >= 0) & (d5 <= d6), np.stack([0 * d1, 0 * d1, np.ones_like(d1)], 1)),
        ]
        t_ab = np.clip(d1 / (d1 - d3), 0, 1)
        regions.append(((vc <= 0) & (d1 >= 0) & (d3 <= 0), np.stack([1 - t_ab, t_ab, 0 * d1], 1)))
        t_ac = np.clip(d2 / (d2 - d6), 0, 1)
        regions.append(((vb <= 0) & (d2 >= 0) & (d6 <= 0), np.stack([1 - t_ac, 0 * d1, t_ac], 1)))
        t_bc = np.clip((d4 - d3) / ((d4 - d3) + (d5 - d6)), 0, 1)
        regions.append(
            ((va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), np.stack([0 * d1, 1 - t_bc, t_bc], 1))
        )
    for mask, weights in reversed(regions):
        bary = np.where(mask[:, None], weights, bary)
    bary = np.nan_to_num(bary)
    closest = a * bary[:, :1] + b * bary[:, 1:2] + c * bary[:, 2:3]
    return closest, bary
