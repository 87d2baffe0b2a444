"""mesh/hull.hull_faces: the faces of a point set's convex hull, held to the definition (the
planes through three of the points with every point on one side), for boxes swept along
segments as the sandbox's sliding crates make them, coplanar and degenerate cases included."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from dentdemo.mesh.hull import hull_faces


def _swept_box(seed: int) -> np.ndarray:
    """A rotated box's 8 corners at both ends of a segment: along one of its axes (faces
    with 8 coplanar points), a general one, or none (every point twice)."""
    rng = np.random.default_rng(seed)
    half = rng.uniform(0.01, 0.3, 3)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    rotation, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    corners = corners @ rotation.T + rng.standard_normal(3)
    shift = [rotation[:, 0] * 0.05, rng.standard_normal(3) * 0.03, np.zeros(3)][seed % 3]
    return np.vstack([corners - shift, corners])


def _planes_by_definition(points: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """Each supporting plane once (outward unit normal, offset): through three points, no
    point beyond it by more than 1e-9 of the points' extent."""
    tolerance = 1e-9 * np.ptp(points, axis=0).max()
    planes: list[tuple[np.ndarray, float]] = []
    for i, j, k in itertools.combinations(range(len(points)), 3):
        n = np.cross(points[j] - points[i], points[k] - points[i])
        if np.linalg.norm(n) < 1e-12:
            continue
        n /= np.linalg.norm(n)
        side = points @ n - n @ points[i]
        if (side > tolerance).any():
            if (side < -tolerance).any():
                continue
            n = -n
        offset = float(n @ points[i])
        if not any(np.allclose(n, m, atol=1e-7) and abs(offset - o) < 1e-7 for m, o in planes):
            planes.append((n, offset))
    return planes


@pytest.mark.parametrize("seed", range(9))
def test_hull_faces_are_the_supporting_planes(seed):
    points = _swept_box(seed)
    faces = hull_faces(points)
    expected = _planes_by_definition(points)
    assert len(faces) == len(expected)
    for face in faces:
        # Newell's normal: a face may keep a corner on its edge (to rounding), where the first
        # three corners' cross product says nothing.
        n = np.cross(face, np.roll(face, -1, axis=0)).sum(axis=0)
        n /= np.linalg.norm(n)
        offset = float(n @ face[0])
        # Counter-clockwise seen from outside: the corners' normal points away from the points.
        assert (points @ n - offset <= 1e-9).all()
        assert (np.abs(face @ n - offset) <= 1e-9).all()  # its corners on one plane
        assert any(np.allclose(n, m, atol=1e-7) and abs(offset - o) < 1e-7 for m, o in expected)
        # Every point on the plane is a corner of the face or on its edges: the face's corners
        # are the plane's points' convex hull, so it has at least three and at most all of them.
        on = points[np.abs(points @ n - offset) <= 1e-9]
        assert 3 <= len(face) <= len(on)
        assert all(any(np.allclose(c, q) for q in on) for c in face)
