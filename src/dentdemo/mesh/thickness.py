"""How thick a body is under each vertex: the distance from the vertex along its inward normal to
the opposite surface (local metres). The carve bounds a texel's dent by it (gather.frag), so no
dent goes through the body, whatever the material's `max_dent_depth` allows.

Built-in solids have closed forms (mesh.bound): a sphere or capsule is 2 r thick along every
inward normal (it passes through the axis); a box is where the ray leaves its convex faces; a plate
is its thickness; a cylinder's side is 2 r and its caps its length. Any other mesh is ray cast on
the CPU, the vertices of each hit's footprint as hits reach them (cached on the mesh): bounding
spheres of triangle clusters pick the triangles each ray is tested against exactly
(Moller-Trumbore). A vertex whose ray leaves an open mesh without a hit gets OPEN (no bound).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dentdemo.mesh.mesh import Bound, Mesh

#: Thickness of a vertex whose inward ray meets nothing (an open mesh's edge, a plate seen from
#: its back): metres, far beyond any dent.
OPEN = 1.0e6

#: Rays per block of the ray cast (memory: a block's rays times the mesh's clusters).
_BLOCK = 1024


def vertex_thickness(mesh: Mesh, which: NDArray[np.int64] | None = None) -> NDArray[np.float32]:
    """The thickness under vertices `which` (all: None), float32 local metres. A built-in shape's
    comes in closed form; any other mesh's is ray cast for the vertices asked for that have not
    been asked for before (cached on the mesh): a hit asks for its footprint's vertices only."""
    closed = closed_thickness(mesh)
    if closed is not None:
        return closed if which is None else closed[which]
    cache = getattr(mesh, "_thickness_cache", None)
    if cache is None or len(cache) != len(mesh.positions):
        cache = np.full(len(mesh.positions), np.nan, dtype=np.float32)
        mesh._thickness_cache = cache  # type: ignore[attr-defined]
    idx = np.arange(len(cache)) if which is None else np.asarray(which, dtype=np.int64)
    missing = np.unique(idx[np.isnan(cache[idx])])
    if len(missing):
        p = mesh.positions[missing].astype(np.float64)
        n = mesh.normals[missing].astype(np.float64)
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        cache[missing] = np.minimum(ray_cast(mesh, p, -n), OPEN)
    return cache[idx]


def closed_thickness(mesh: Mesh) -> NDArray[np.float32] | None:
    """Every vertex's thickness for a built-in shape (cached), None for any other mesh."""
    if mesh.bound is None:
        return None
    cached = getattr(mesh, "_closed_thickness", None)
    if cached is not None and len(cached) == len(mesh.positions):
        return cached
    p = mesh.positions.astype(np.float64)
    n = mesh.normals.astype(np.float64)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    t = _closed_form(mesh.bound, p, n)
    if t is None:
        return None
    result = np.minimum(t, OPEN).astype(np.float32)
    mesh._closed_thickness = result  # type: ignore[attr-defined]
    return result


def _closed_form(
    bound: Bound, p: NDArray[np.float64], n: NDArray[np.float64]
) -> NDArray[np.float64] | None:
    if bound.segment is not None and bound.exact:  # sphere, capsule: through the axis
        return np.full(len(p), 2.0 * bound.radius)
    if bound.segment is not None:  # cylinder about the segment
        return _cylinder_exit(bound.segment, bound.radius, p, -n)
    if bound.triangles is not None and bound.depth > 0.0:  # a plate's top face over its slab
        return np.full(len(p), bound.depth)
    if bound.triangles is not None:  # a box: a convex solid's faces (a bare plate: none, OPEN)
        return _convex_exit(bound.triangles, p, -n)
    return None


def _convex_exit(
    faces: NDArray[np.float64], p: NDArray[np.float64], d: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Where rays p + t d (d unit, p on the surface) leave the convex solid bounded by `faces`
    (k, 3, 3), each wound counter-clockwise seen from outside: the nearest plane they cross
    outwards, ignoring the plane they start on."""
    a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
    normal = np.cross(b - a, c - a)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
    offset = (normal * a).sum(axis=1)  # plane: normal . x = offset
    outwards = d @ normal.T  # (rays, faces)
    gap = offset[None, :] - p @ normal.T  # >= 0 inside
    scale = float(np.abs(faces).max())
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(outwards > 1e-12, gap / outwards, np.inf)
    t = np.where(t > 1e-9 * scale, t, np.inf)  # the plane the ray starts on
    return t.min(axis=1)


def _cylinder_exit(
    segment: NDArray[np.float64], radius: float, p: NDArray[np.float64], d: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Where rays p + t d leave the solid cylinder of `radius` about `segment` (2, 3)."""
    axis = segment[1] - segment[0]
    length = float(np.linalg.norm(axis))
    axis /= length
    rel = p - segment[0]
    # Caps: the slab 0 <= (x - a) . axis <= length.
    along, speed = rel @ axis, d @ axis
    scale = max(length, radius)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_cap = np.where(
            speed > 1e-12,
            (length - along) / speed,
            np.where(speed < -1e-12, -along / speed, np.inf),
        )
    t_cap = np.where(t_cap > 1e-9 * scale, t_cap, np.inf)
    # Side: |radial(x)| = radius, the larger root (the ray starts inside or on it).
    r0 = rel - along[:, None] * axis
    dr = d - speed[:, None] * axis
    qa = (dr * dr).sum(axis=1)
    qb = 2.0 * (r0 * dr).sum(axis=1)
    qc = (r0 * r0).sum(axis=1) - radius * radius
    disc = np.maximum(qb * qb - 4.0 * qa * qc, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_side = np.where(qa > 1e-12, (-qb + np.sqrt(disc)) / (2.0 * qa), np.inf)
    t_side = np.where(t_side > 1e-9 * scale, t_side, np.inf)
    return np.minimum(t_cap, t_side)


def ray_cast(
    mesh: Mesh, origin: NDArray[np.float64], direction: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Distance from each origin along its unit direction to the first triangle of `mesh` it
    crosses beyond a small start offset (inf: none), local metres.

    The clusters whose bounding spheres a ray passes through are visited in the order the ray
    enters them, one round per cluster for every ray at once; a ray stops once its nearest hit
    lies before the next cluster's entry, so most rays test a few clusters, not all they pass."""
    corners = mesh.corner_array()
    group_centre, group_radius, members = mesh.clusters()
    scale = float(np.abs(corners).max()) if len(corners) else 1.0
    start = 1e-6 * scale  # leaves the triangles the ray starts on
    out = np.full(len(origin), np.inf)
    for lo in range(0, len(origin), _BLOCK):
        o, d = origin[lo : lo + _BLOCK], direction[lo : lo + _BLOCK]
        rel = group_centre[None, :, :] - o[:, None, :]  # (rays, groups, 3)
        along = (rel * d[:, None, :]).sum(axis=2)
        half2 = group_radius[None, :] ** 2 - ((rel * rel).sum(axis=2) - along**2)
        exit_t = along + np.sqrt(np.maximum(half2, 0.0))
        ray, group = np.nonzero((half2 >= 0.0) & (exit_t >= 0.0))
        entry = along[ray, group] - np.sqrt(half2[ray, group])
        order = np.lexsort((entry, ray))  # by ray, then by entry along it
        ray, group, entry = ray[order], group[order], entry[order]
        first = np.searchsorted(ray, np.arange(len(o)))  # each ray's first pair
        count = np.bincount(ray, minlength=len(o))
        best = np.full(len(o), np.inf)
        live = np.nonzero(count)[0]
        rank = 0
        while len(live):
            pair = first[live] + rank
            tris = members[group[pair]]  # (live, CLUSTER_SIZE)
            rays = np.repeat(live, tris.shape[1])
            tris = tris.ravel()
            keep = tris >= 0
            rays, tris = rays[keep], tris[keep]
            t = _moller_trumbore(o[rays], d[rays], corners[tris])
            t = np.where(t > start, t, np.inf)
            np.minimum.at(best, rays, t)
            rank += 1
            more = rank < count[live]
            nxt = np.where(more, first[live] + rank, 0)
            live = live[more & (best[live] > entry[nxt])]
        out[lo : lo + len(o)] = best
    return out


def _moller_trumbore(
    o: NDArray[np.float64], d: NDArray[np.float64], tri: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Ray parameter of each ray's crossing of its triangle (k, 3, 3), inf where it misses."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    e1, e2 = b - a, c - a
    pvec = np.cross(d, e2)
    det = (e1 * pvec).sum(axis=1)
    ok = np.abs(det) > 1e-18
    inv = 1.0 / np.where(ok, det, 1.0)
    s = o - a
    u = (s * pvec).sum(axis=1) * inv
    qvec = np.cross(s, e1)
    v = (d * qvec).sum(axis=1) * inv
    t = (e2 * qvec).sum(axis=1) * inv
    tol = 1e-9
    hit = ok & (u >= -tol) & (v >= -tol) & (u + v <= 1.0 + tol)
    return np.where(hit, t, np.inf)
