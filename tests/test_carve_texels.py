"""Carve v2, texel by texel (issue 19, item 7): the last texel row of a box face pressed face-first,
single texels left undented inside deep dents on a bumpy re-atlased mesh, and the normal rebuild's
per-texel metric on a curved chart. Expected values come from the press's geometry and from numpy
rasters of the meshes' own uv triangles, never from the code under test."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dentdemo.carve.camera import ContactFrame
from dentdemo.mesh.loader import reatlas
from dentdemo.mesh.mesh import Mesh
from dentdemo.mesh.normals import smooth_normals
from dentdemo.mesh.primitives import sphere as sphere_mesh
from dentdemo.model.shapes import Box, Plate, Sphere
from surface_helpers import DENTED, heights, holes, press_mesh, rotation, translation


# -- numpy rasters of a mesh's uv triangles --------------------------------------------------------
def uv_raster(mesh: Mesh, size: int, which: np.ndarray | None = None):
    """For every texel whose centre ((i + 0.5) / size) lies inside one of the mesh's uv triangles
    (`which`: a subset), the triangle and the barycentric weights of the centre; -1 elsewhere.
    Centres on an edge shared by two triangles count (either triangle). Also returns the texels
    whose centre lies within 1/64 texel of any edge, where GL's fill rule and the rasteriser's
    sub-texel snapping of the corners (8 bits on llvmpipe and NVIDIA) decide which triangle (or,
    on a chart's border, whether any) draws it."""
    tris = np.arange(len(mesh.indices)) if which is None else np.asarray(which)
    owner = np.full((size, size), -1, dtype=np.int64)
    weights = np.zeros((size, size, 3))
    on_edge = np.zeros((size, size), dtype=bool)
    uv = mesh.uvs.astype(np.float64)[mesh.indices[tris]] * size  # (k, 3, 2) texel units
    for k, tri in zip(tris, uv, strict=True):
        lo = np.clip(np.floor(tri.min(axis=0)).astype(int) - 1, 0, size - 1)
        hi = np.clip(np.ceil(tri.max(axis=0)).astype(int) + 1, 0, size - 1)
        cols, rows = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1))
        p = np.stack([cols + 0.5, rows + 0.5], axis=-1)
        e1, e2 = tri[1] - tri[0], tri[2] - tri[0]
        den = e1[0] * e2[1] - e1[1] * e2[0]
        if abs(den) < 1e-12:
            continue
        r = p - tri[0]
        b1 = (r[..., 0] * e2[1] - r[..., 1] * e2[0]) / den
        b2 = (e1[0] * r[..., 1] - e1[1] * r[..., 0]) / den
        b = np.stack([1 - b1 - b2, b1, b2], axis=-1)
        # Signed distance of the centre to each edge, texels (the weight over the height).
        heights_ = np.array(
            [abs(den) / np.linalg.norm(tri[(i + 2) % 3] - tri[(i + 1) % 3]) for i in range(3)]
        )
        dist = b * heights_
        inside = dist.min(axis=-1) >= -1e-9
        on_edge[rows, cols] |= np.abs(dist).min(axis=-1) <= 1.0 / 64.0
        owner[rows[inside], cols[inside]] = k
        weights[rows[inside], cols[inside]] = b[inside]
    return owner, weights, on_edge


# -- 1: a box pressed face-first leaves no texel row of its face undented --------------------------
@pytest.mark.parametrize(
    "edge,plate_side,plate_map",
    [
        # (box edge, plate side, plate map): the plate's texels are 1.6x, 3.2x and 9.7x the box's
        # along v, so the camera's pixel spans 1, 2 and 9 of the box's texels; the face's far edge
        # row, its near edge row, and several rows lie between a pixel centre and the face's edge.
        (0.1, 0.5, 256),
        (0.1, 1.0, 256),
        (0.05, 1.0, 256),
        (0.1, 0.5, 512),
    ],
)
def test_a_box_face_pressed_into_a_plate_is_dented_to_its_last_texel(
    gl, carver, bodies, edge, plate_side, plate_map
):
    size, depth, tool_depth = 256, 0.005, 0.003
    plate = bodies.make(press_mesh(Plate(plate_side), 2), plate_map)
    mesh = press_mesh(Box((edge, edge, edge)), 2)
    box = bodies.make(mesh, size)
    box.model = translation((0.0, edge / 2, 0.0))  # bottom face on the plate (y = 0)
    carver.carve(
        plate, box, ContactFrame(np.zeros(3), np.array([0.0, -1.0, 0.0])), depth, tool_depth
    )
    # The bottom face: the triangles whose three corners lie at y = -edge / 2.
    corners = mesh.positions.astype(np.float64)[mesh.indices]
    bottom = np.nonzero(np.all(np.abs(corners[..., 1] + edge / 2) < 1e-9, axis=1))[0]
    assert len(bottom) >= 2
    owner, _, _ = uv_raster(mesh, size, bottom)
    face = owner >= 0
    assert face.sum() > 0.8 * (size / 3) * (size / 2)  # the whole chart of the face
    h = heights(gl, box)
    # The plate is flat and the face is flat: the face sinks by the tool depth everywhere.
    err = np.abs(h[face] + tool_depth)
    bad = face & (np.abs(h + tool_depth) > 1e-6)
    rows = np.unique(np.nonzero(bad)[0])
    print(
        f"box {edge} on plate {plate_side}@{plate_map}: {bad.sum()} of {face.sum()} face texels "
        f"off (rows {rows.tolist()[:12]}), worst {err.max():.2e} m"
    )
    assert bad.sum() == 0, f"{bad.sum()} face texels not at -tool_depth, rows {rows.tolist()[:12]}"
    # And the plate is dented by the face's print (the first direction of the same hit).
    hp = heights(gl, plate)
    c = (np.arange(plate_map) + 0.5) / plate_map
    x, z = (
        (c[None, :] - 0.5) * plate_side + 0 * c[:, None],
        (0.5 - c[:, None]) * plate_side + 0 * c[None, :],
    )
    under = (np.abs(x) < edge / 2 - 1e-9) & (np.abs(z) < edge / 2 - 1e-9)
    assert np.abs(hp[under] + depth).max() <= 1e-6


# -- 2: no single texel left undented inside a deep dent on a bumpy re-atlased mesh ----------------
_BUMPY: dict[tuple, Mesh] = {}


def bumpy_sphere(radius: float, subdivisions: int, amplitude: float, seed: int) -> Mesh:
    """An icosphere whose vertices are moved radially by random amounts (up to `amplitude` of the
    radius), with smooth normals, re-atlased by xatlas as the loader does for a scan without
    texture coordinates: small, sharply curved triangles whose interpolated normals turn well
    away from their faces, as on a real scan (the Stanford bunny)."""
    key = (radius, subdivisions, amplitude, seed)
    if key not in _BUMPY:
        import trimesh

        ico = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
        v = np.asarray(ico.vertices, dtype=np.float64)
        rng = np.random.default_rng(seed)
        positions = v * (radius * (1.0 + amplitude * rng.uniform(-1.0, 1.0, len(v))))[:, None]
        normals, faces, source = smooth_normals(positions, np.asarray(ico.faces, dtype=np.uint32))
        positions, normals, uvs, faces = reatlas(positions[source], faces, normals)
        _BUMPY[key] = Mesh("bumpy", positions, normals, uvs, faces)
    return _BUMPY[key]


def unoccluded_from_below(points: np.ndarray, tris: np.ndarray, cell: float) -> np.ndarray:
    """Whether the vertical line from each point (n, 3) down (-y) meets none of the triangles
    (m, 3, 3) below it (a triangle through the point itself does not count): the point is seen
    by a tool coming up from below. Triangles are binned on an x, z grid of `cell` metres."""
    free = np.ones(len(points), dtype=bool)
    lo = np.floor(tris[..., [0, 2]].min(axis=1) / cell).astype(int)
    hi = np.floor(tris[..., [0, 2]].max(axis=1) / cell).astype(int)
    key = np.floor(points[:, [0, 2]] / cell).astype(int)
    bins: dict[tuple[int, int], list[int]] = {}
    for k in range(len(tris)):
        for i in range(lo[k, 0], hi[k, 0] + 1):
            for j in range(lo[k, 1], hi[k, 1] + 1):
                bins.setdefault((i, j), []).append(k)
    order = np.lexsort((key[:, 1], key[:, 0]))
    sorted_keys = key[order]
    starts = np.r_[0, np.nonzero(np.any(np.diff(sorted_keys, axis=0) != 0, axis=1))[0] + 1]
    ends = np.r_[starts[1:], len(order)]
    for s, e in zip(starts, ends, strict=True):
        cand = bins.get(tuple(sorted_keys[s]), [])
        if not cand:
            continue
        who = order[s:e]
        p = points[who]  # (a, 3)
        t = tris[cand]  # (b, 3, 3)
        a, b, c = t[:, 0], t[:, 1], t[:, 2]
        # Barycentric weights of each point's x, z in each triangle's x, z.
        e1, e2 = (b - a)[:, [0, 2]], (c - a)[:, [0, 2]]
        den = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        ok = np.abs(den) > 1e-18
        den = np.where(ok, den, 1.0)
        r = p[:, None, [0, 2]] - a[None, :, [0, 2]]  # (a, b, 2)
        w1 = (r[..., 0] * e2[:, 1] - r[..., 1] * e2[:, 0]) / den
        w2 = (e1[:, 0] * r[..., 1] - e1[:, 1] * r[..., 0]) / den
        w0 = 1.0 - w1 - w2
        inside = ok & (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
        y = w0 * a[:, 1] + w1 * b[:, 1] + w2 * c[:, 1]
        below = inside & (y < p[:, None, 1] - 1e-6)
        free[who] = ~below.any(axis=1)
    return free


@pytest.mark.parametrize(
    "subdivisions,amplitude,seed,tool_map",
    [(4, 0.06, 1, 1024), (4, 0.1, 3, 1024), (4, 0.06, 1, 256)],
    ids=["bumpy-fine-pixels", "rough-fine-pixels", "bumpy-coarse-pixels"],
)
@pytest.mark.slow
def test_no_single_texel_stays_undented_in_a_deep_dent_on_a_bumpy_mesh(
    gl, carver, bodies, subdivisions, amplitude, seed, tool_map
):
    radius, size, depth, max_dent = 0.1, 1024, 0.025, 0.1
    mesh = bumpy_sphere(radius, subdivisions, amplitude, seed)
    target = bodies.make(mesh, size, max_dent_depth=max_dent)
    positions = mesh.positions.astype(np.float64)
    low = float(positions[:, 1].min())
    # A large slab (0.3 m x 0.02 m x 0.3 m) comes up from below and presses `depth` past first
    # touch: its top face ends at y = low + depth. With a map of 256 the slab's texels are 4.5
    # of the target's and so is a camera pixel; with 1024, about one.
    slab = bodies.make(press_mesh(Box((0.3, 0.02, 0.3)), 1), tool_map)
    slab.model = translation((0.0, low - 0.01, 0.0))
    up = np.array([0.0, 1.0, 0.0])
    carver.carve(target, slab, ContactFrame(np.array([0.0, low, 0.0]), up), depth)
    h = heights(gl, target)
    top = low + depth

    # Every chart texel from the mesh's own uv triangles: its triangle, its point and normal.
    owner, weights, on_edge = uv_raster(mesh, size)
    chart = (owner >= 0) & ~on_edge
    tri = mesh.indices.astype(np.int64)
    corners = positions[tri]  # (m, 3, 3)
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    facing = face @ up < 0.0  # the triangle faces the slab coming up (-y side out)
    rows, cols = np.nonzero(chart)
    k = owner[rows, cols]
    w = weights[rows, cols]
    point = np.einsum("kj,kjc->kc", w, corners[k])
    normal = np.einsum("kj,kjc->kc", w, mesh.normals.astype(np.float64)[tri[k]])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    texel = math.sqrt(4 * math.pi * radius**2 / chart.sum())  # about one texel's side, metres

    # 1. No holes among the chart texels whose triangle faces the slab (a triangle facing away,
    # a fold of the surface, is hidden behind the ones in front by construction).
    front = np.zeros_like(chart)
    front[rows, cols] = facing[k]
    d = h < DENTED
    hole = np.zeros_like(d)
    hole[1:-1, 1:-1] = ~d[1:-1, 1:-1] & d[:-2, 1:-1] & d[2:, 1:-1] & d[1:-1, :-2] & d[1:-1, 2:]
    hole &= front
    print(
        f"holes in facing chart texels: {hole.sum()} (holes() on all: {holes(h)}); "
        f"dented {d.sum()}, deepest {-h.min() * 1e3:.1f} mm"
    )
    assert d.sum() > 5000
    assert hole.sum() == 0, f"{hole.sum()} holes at {np.argwhere(hole)[:6].tolist()}"

    # 2. The depth of the dent follows the geometry. A facing texel whose point lies more than a
    # texel inside the slab, and which nothing below hides (the line from it down along the press
    # meets no other triangle), is dented to where the slab's top face is along its normal:
    # h = -(top - y) / max(cos, MIN_COS), cos = -n . up (the method's model).
    inside = facing[k] & (point[:, 1] < top - texel)
    below = corners[corners[..., 1].min(axis=1) < top]
    seen = inside.copy()
    seen[inside] = unoccluded_from_below(point[inside], below, 0.004)
    cos = np.maximum(-(normal @ up), 0.2)  # MIN_COS, docs/carve.md
    # No deeper than the mesh is thick under the texel: each vertex's distance along its inward
    # normal to where that line leaves the mesh (a bump's flank, on this mesh, for some), by
    # brute force over every triangle, interpolated like the texel's point.
    thick = np.full(len(positions), np.inf)
    needed = np.unique(tri[k[seen]])
    thick[needed] = _exit_distance(positions[needed], -mesh.normals[needed], corners)
    bound = np.einsum("kj,kj->k", w, thick[tri[k]])
    expected = np.maximum(-(top - point[:, 1]) / cos, -np.minimum(max_dent, bound))
    got = h[rows, cols]
    undented = seen & ~(got < DENTED)
    err = np.abs(got - expected)[seen]
    print(
        f"texels under the slab's face, seen from it: {seen.sum()}, undented {undented.sum()}, "
        f"worst {err.max() * 1e3:.4f} mm"
    )
    assert seen.sum() > 2000
    assert undented.sum() == 0, f"{undented.sum()} texels under the slab left undented"
    assert err.max() <= 1e-5


def _exit_distance(origin: np.ndarray, direction: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """For each ray, the nearest crossing of any triangle (m, 3, 3) beyond 1e-7 m (Moller-Trumbore
    against all of them, in chunks)."""
    d = direction / np.linalg.norm(direction, axis=1, keepdims=True)
    a, e1, e2 = corners[:, 0], corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    out = np.full(len(origin), np.inf)
    for lo in range(0, len(origin), 64):
        o, dd = origin[lo : lo + 64, None, :], d[lo : lo + 64, None, :]
        p = np.cross(dd, e2[None])
        det = (e1[None] * p).sum(axis=2)
        inv = 1.0 / np.where(np.abs(det) > 1e-18, det, np.inf)
        sv = o - a[None]
        u = (sv * p).sum(axis=2) * inv
        q = np.cross(sv, e1[None])
        v = (dd * q).sum(axis=2) * inv
        t = (e2[None] * q).sum(axis=2) * inv
        hit = (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9) & (t > 1e-7)
        out[lo : lo + 64] = np.where(hit, t, np.inf).min(axis=1)
    return out


# -- 3: the normal rebuild uses each texel's own metric --------------------------------------------
def metric_normals(mesh: Mesh, model: np.ndarray, h: np.ndarray, size: int):
    """Tangent-space normals from the heights `h` alone, in numpy: central differences along +u
    and +v (one-sided where a neighbour lies outside every chart), turned into slopes through
    each texel's own metric, its triangle's dP/du and dP/dv (metres per texel), with T along
    dP/du and B perpendicular to it in the surface on the side of +v. Also returns the chart."""
    owner, _, on_edge = uv_raster(mesh, size)
    chart = owner >= 0
    tri = mesh.indices.astype(np.int64)
    p = mesh.positions.astype(np.float64)[tri] @ model[:3, :3].T  # (m, 3, 3) world
    uv = mesh.uvs.astype(np.float64)[tri] * size  # texels
    d1, d2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    det = np.where(np.abs(det) > 1e-12, det, np.nan)
    per_u = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) / det[:, None]
    per_v = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) / det[:, None]
    k = np.where(chart, owner, 0)
    pu, pv = per_u[k], per_v[k]
    hp = np.pad(h.astype(np.float64), 1)
    cp = np.pad(chart, 1)

    def difference(dr: int, dc: int) -> np.ndarray:
        lo_in = cp[1 - dr : 1 - dr + size, 1 - dc : 1 - dc + size]
        hi_in = cp[1 + dr : 1 + dr + size, 1 + dc : 1 + dc + size]
        lo = np.where(lo_in, hp[1 - dr : 1 - dr + size, 1 - dc : 1 - dc + size], h)
        hi = np.where(hi_in, hp[1 + dr : 1 + dr + size, 1 + dc : 1 + dc + size], h)
        span = lo_in.astype(float) + hi_in
        return np.where(span > 0, (hi - lo) / np.maximum(span, 1), 0.0)

    du, dv = difference(0, 1), difference(1, 0)
    a = np.linalg.norm(pu, axis=-1)
    t = pu / a[..., None]
    b = (pv * t).sum(-1)
    c = np.linalg.norm(pv - b[..., None] * t, axis=-1)
    g_t = du / a
    g_b = (dv - g_t * b) / c
    n = np.stack([-g_t, -g_b, np.ones_like(g_t)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return n, chart, on_edge


def _decode(rgba: np.ndarray) -> np.ndarray:
    n = rgba[..., :3].astype(np.float64) / 255.0 * 2 - 1
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


@pytest.mark.parametrize("target", ["sphere-24", "sphere-8", "plate"])
@pytest.mark.slow
def test_rebuilt_normals_follow_the_heights_through_each_texel_s_metric(gl, carver, bodies, target):
    size, depth = 512, 0.012
    if target == "plate":
        mesh = press_mesh(Plate(0.5), 2)
        point, normal = np.array([0.03, 0.0, -0.02]), np.array([0.0, 1.0, 0.0])
    else:
        radius = 0.2
        # A built-in sphere (its own smooth solid) of 24 or 8 cells a cube face; the press lands
        # 30 degrees off the +Y chart's centre towards its corner, where the chart's texels are
        # sheared and unevenly scaled.
        mesh = sphere_mesh(radius, int(target.split("-")[1]))
        normal = np.array(
            [
                math.sin(math.radians(30)) / math.sqrt(2),
                math.cos(math.radians(30)),
                -math.sin(math.radians(30)) / math.sqrt(2),
            ]
        )
        point = radius * normal
    body = bodies.make(mesh, size)
    model = np.eye(4)
    if target == "plate":
        tool = bodies.make(press_mesh(Sphere(0.05), 2), 256)
        tool.model = translation(point + 0.05 * normal)
    else:
        # A large flat box face: a flat facet cut into the sphere.
        tool = bodies.make(press_mesh(Box((0.2, 0.2, 0.2)), 2), 64)
        axis = np.cross([0.0, -1.0, 0.0], -normal)
        angle = math.degrees(math.acos(np.clip(normal[1], -1, 1)))
        turn = rotation(axis, angle) if np.linalg.norm(axis) > 1e-9 else np.eye(4)
        tool.model = translation(point + 0.1 * normal) @ turn
    carver.carve(body, tool, ContactFrame(point, -normal), depth)
    h = heights(gl, body)
    got = _decode(gl.read(body.maps.normal))
    expected, chart, on_edge = metric_normals(mesh, model, h, size)
    # Where the texel and its four neighbours are dented (the rim's kink is no gradient) and all
    # five lie inside a chart, away from fill-rule edges.
    d = (h < DENTED) & chart & ~on_edge
    inner = np.zeros_like(d)
    inner[1:-1, 1:-1] = d[1:-1, 1:-1] & d[:-2, 1:-1] & d[2:, 1:-1] & d[1:-1, :-2] & d[1:-1, 2:]
    err = np.degrees(np.arccos(np.clip((got[inner] * expected[inner]).sum(-1), -1, 1)))
    print(
        f"{target}: {inner.sum()} texels, mean {err.mean():.2f} deg, "
        f"p95 {np.percentile(err, 95):.2f} deg, max {err.max():.2f} deg"
    )
    assert inner.sum() > 500
    assert np.percentile(err, 95) <= 1.5 and err.mean() <= 0.75
