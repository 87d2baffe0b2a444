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
    seen: list[tuple[NDArray[np.float64], float]] = []
    for i, j, k in itertools.combinations(range(len(p)), 3):
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
        if any(np.allclose(normal, n, atol=1e-9) and abs(offset - o) <= tolerance for n, o in seen):
            continue
        seen.append((normal, offset))
        on = p[np.abs(side) <= tolerance]
        a = on[np.argmax(np.linalg.norm(on - on[0], axis=1))] - on[0]
        a /= np.linalg.norm(a)
        b = np.cross(normal, a)
        flat = np.stack([(on - on[0]) @ a, (on - on[0]) @ b], axis=1)
        faces.append(on[convex_ring(flat, tolerance)])
    return faces


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
