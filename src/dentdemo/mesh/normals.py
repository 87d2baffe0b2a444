"""Vertex normals as an artist's mesh expects them: faces that meet at the same position are
averaged (area-weighted) even where the vertex is split at a UV seam or stored once per triangle
(STL), and edges sharper than a crease angle stay hard (their corners get split vertices)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: Faces meeting at more than this angle keep a hard edge, degrees.
CREASE_DEG = 60.0


def smooth_normals(
    positions: NDArray[np.floating],
    indices: NDArray[np.integer],
    crease_deg: float = CREASE_DEG,
) -> tuple[NDArray[np.float64], NDArray[np.uint32], NDArray[np.int64]]:
    """(normals, new indices, source vertex of each new vertex): each corner's normal is the
    area-weighted sum of the face normals at its position (within 1e-7 of the mesh's size) that
    lie within `crease_deg` of its own face's; a vertex whose corners disagree is split."""
    p = np.asarray(positions, dtype=np.float64)
    tris = np.asarray(indices, dtype=np.int64).reshape(-1, 3)
    m = len(tris)
    a, b, c = p[tris[:, 0]], p[tris[:, 1]], p[tris[:, 2]]
    face = np.cross(b - a, c - a)  # length: twice the area
    unit = face / np.maximum(np.linalg.norm(face, axis=1, keepdims=True), 1e-300)

    # Weld by position: vertices closer than a tolerance share a group.
    scale = max(float(np.ptp(p, axis=0).max()), 1e-12)
    keys = np.round(p / (scale * 1e-7)).astype(np.int64)
    _, group = np.unique(keys, axis=0, return_inverse=True)
    group = group.ravel()

    corner_group = group[tris].ravel()  # (3m,)
    corner_face = np.repeat(np.arange(m), 3)
    # Every (corner, face at the same position) pair, through a sort by group.
    order = np.argsort(corner_group, kind="stable")
    sorted_groups = corner_group[order]
    starts = np.searchsorted(sorted_groups, corner_group, side="left")
    ends = np.searchsorted(sorted_groups, corner_group, side="right")
    counts = ends - starts
    corner_of_pair = np.repeat(np.arange(3 * m), counts)
    offsets = np.arange(len(corner_of_pair)) - np.repeat(np.cumsum(counts) - counts, counts)
    face_of_pair = corner_face[order[np.repeat(starts, counts) + offsets]]
    # A face meets a position in one corner; the same face listed twice (a degenerate welded
    # triangle) is counted once per corner, which only repeats its own weight.
    keep = (unit[face_of_pair] * unit[corner_face[corner_of_pair]]).sum(1) >= np.cos(
        np.radians(crease_deg)
    )
    summed = np.zeros((3 * m, 3))
    np.add.at(summed, corner_of_pair[keep], face[face_of_pair[keep]])
    length = np.linalg.norm(summed, axis=1, keepdims=True)
    corner_normal = np.where(length > 0, summed / np.maximum(length, 1e-300), unit[corner_face])

    # One vertex per (source vertex, normal): split where corners disagree.
    quantised = np.round(corner_normal * 1e5).astype(np.int64)
    corner_vertex = tris.ravel()
    key = np.concatenate([corner_vertex[:, None], quantised], axis=1)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    new_indices = inverse.ravel().reshape(-1, 3).astype(np.uint32)
    return corner_normal[first], new_indices, corner_vertex[first]
