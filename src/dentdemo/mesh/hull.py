"""The convex hull of a few points as a carve tool: a box swept along a segment (the hull of its
corners at both ends) for a scratch (app/wear.py). Local metres. Brute force over the points'
triples, for the dozen or two points a swept box has; flat faces, one atlas cell per triangle."""

from __future__ import annotations

import itertools
import math

import numpy as np
from numpy.typing import NDArray

from dentdemo.mesh.mesh import Bound, Mesh

#: Points nearer a face's plane than this times the points' extent lie on it.
PLANE_TOLERANCE = 1e-9


def hull_faces(points: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """The hull's faces, each its corners (k, 3) counter-clockwise seen from outside."""
    p = np.asarray(points, dtype=np.float64)
    scale = max(float(np.ptp(p, axis=0).max()), 1e-30)
    tolerance = PLANE_TOLERANCE * scale
    faces: list[NDArray[np.float64]] = []
    seen_normals: list[NDArray[np.float64]] = []
    seen_offsets: list[float] = []
    for i, j, k in _candidate_triples(p, tolerance, scale):
        normal = np.cross(p[j] - p[i], p[k] - p[i])
        length = float(np.linalg.norm(normal))
        if length < tolerance * scale:
            continue
        normal /= length
        offset = float(normal @ p[i])
        side = p @ normal - offset
        if (side > tolerance).any():
            if (side < -tolerance).any():
                continue
            normal, offset, side = -normal, -offset, -side
        if seen_normals and _seen(normal, offset, seen_normals, seen_offsets, tolerance):
            continue
        seen_normals.append(normal)
        seen_offsets.append(offset)
        on = p[np.abs(side) <= tolerance]
        a = on[np.argmax(np.linalg.norm(on - on[0], axis=1))] - on[0]
        a /= np.linalg.norm(a)
        b = np.cross(normal, a)
        flat = np.stack([(on - on[0]) @ a, (on - on[0]) @ b], axis=1)
        faces.append(on[convex_ring(flat, tolerance)])
    return faces


def _candidate_triples(
    p: NDArray[np.float64], tolerance: float, scale: float
) -> list[tuple[int, int, int]]:
    """The triples of points, in `itertools.combinations` order, whose plane `hull_faces` may
    keep: those that are, as all triples at once, clearly degenerate or clearly cut by the
    hull are left out. "Clearly": by twice the tolerance, so that the rounding of the array
    arithmetic (other than `hull_faces`' own, a triple at a time) decides no triple; each one
    kept is tested again there, with the bits it always had."""
    triples = np.array(list(itertools.combinations(range(len(p)), 3)), dtype=np.int64)
    if len(triples) == 0:
        return []
    a, b, c = p[triples[:, 0]], p[triples[:, 1]], p[triples[:, 2]]
    normal = np.cross(b - a, c - a)
    length = np.sqrt((normal * normal).sum(axis=1))
    degenerate = length < 0.5 * tolerance * scale
    unit = normal / np.where(degenerate, 1.0, length)[:, None]
    side = unit @ p.T - (unit * a).sum(axis=1)[:, None]
    cut = (side > 2.0 * tolerance).any(axis=1) & (side < -2.0 * tolerance).any(axis=1)
    return [tuple(row) for row in triples[~(degenerate | cut)].tolist()]


def _seen(
    normal: NDArray[np.float64],
    offset: float,
    normals: list[NDArray[np.float64]],
    offsets: list[float],
    tolerance: float,
) -> bool:
    """Whether a face's plane (unit `normal`, `offset`) is one of those found already: its
    normal `np.allclose` to theirs (atol 1e-9, numpy's rtol 1e-5) and its offset within
    `tolerance`, all of them compared at once."""
    known = np.asarray(normals)
    close = (np.abs(normal - known) <= 1e-9 + 1e-5 * np.abs(known)).all(axis=1)
    return bool((close & (np.abs(offset - np.asarray(offsets)) <= tolerance)).any())


def convex_ring(flat: NDArray[np.float64], tolerance: float) -> list[int]:
    """Indices of the 2D points' convex hull, counter-clockwise, without collinear or repeated
    points (Andrew's monotone chain)."""
    order = sorted(range(len(flat)), key=lambda i: (flat[i, 0], flat[i, 1]))

    def turn(o: int, a: int, b: int) -> float:
        u, v = flat[a] - flat[o], flat[b] - flat[o]
        return float(u[0] * v[1] - u[1] * v[0])

    def chain(indices: list[int]) -> list[int]:
        out: list[int] = []
        for i in indices:
            while len(out) >= 2 and turn(out[-2], out[-1], i) <= tolerance * tolerance:
                out.pop()
            out.append(i)
        return out[:-1]

    return chain(order) + chain(order[::-1])


def hull_mesh(points: NDArray[np.float64], name: str = "swept") -> Mesh:
    """The convex hull of `points` as a Mesh: flat faces fanned into triangles, each triangle in
    a cell of a square grid of the atlas (a unique atlas), bound by its own faces (a convex
    solid, as a box)."""
    triangles = [
        np.stack([face[0], face[n], face[n + 1]])
        for face in hull_faces(points)
        for n in range(1, len(face) - 1)
    ]
    corners = np.asarray(triangles)  # (t, 3, 3)
    count = len(corners)
    cells = math.ceil(math.sqrt(count))
    uvs = np.empty((count, 3, 2))
    for t, tri in enumerate(corners):
        # The triangle in its own plane, fitted into its cell with a margin.
        a = tri[1] - tri[0]
        a /= np.linalg.norm(a)
        n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
        b = np.cross(n / np.linalg.norm(n), a)
        flat = np.stack([(tri - tri[0]) @ a, (tri - tri[0]) @ b], axis=1)
        flat -= flat.min(axis=0)
        span = max(float(flat.max()), 1e-30)
        row, col = divmod(t, cells)
        uvs[t] = (np.array([col, row]) + 0.1 + 0.8 * flat / span) / cells
    normals = np.repeat(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), 3, 0
    )
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    mesh = Mesh(
        name,
        corners.reshape(-1, 3).astype(np.float32),
        normals.astype(np.float32),
        uvs.reshape(-1, 2).astype(np.float32),
        np.arange(3 * count, dtype=np.uint32).reshape(-1, 3),
    )
    mesh.bound = Bound(triangles=corners)
    return mesh
