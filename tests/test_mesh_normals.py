"""Meshes as artists deliver them: normals smooth across UV seams and across triangles stored
apart (STL), hard edges kept above the crease angle."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dentdemo.mesh.loader import load_mesh, mesh_from_triangles
from dentdemo.mesh.normals import CREASE_DEG

R, r = 0.2, 0.07  # torus radii, m


def uv_torus(nu: int = 48, nv: int = 24):
    """A torus with its own UVs, split at both seams ((nu+1) x (nv+1) vertices), and the exact
    normal of each vertex (from the centre of the tube)."""
    u = np.linspace(0, 2 * np.pi, nu + 1)
    v = np.linspace(0, 2 * np.pi, nv + 1)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    centre = np.stack([R * np.cos(uu), np.zeros_like(uu), R * np.sin(uu)], -1)
    normal = np.stack([np.cos(vv) * np.cos(uu), np.sin(vv), np.cos(vv) * np.sin(uu)], -1)
    positions = (centre + r * normal).reshape(-1, 3)
    uvs = np.stack([uu / (2 * np.pi), vv / (2 * np.pi)], -1).reshape(-1, 2) * 0.98 + 0.01
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    faces = np.concatenate(
        [np.stack([a, d, b], -1).reshape(-1, 3), np.stack([b, d, c], -1).reshape(-1, 3)]
    )
    return positions, faces, uvs, normal.reshape(-1, 3)


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    cos = (a * b).sum(-1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def test_normals_agree_at_split_seam_vertices():
    positions, faces, uvs, exact = uv_torus()
    mesh = mesh_from_triangles(positions, faces, uvs, name="torus")
    # Every group of vertices at one position (the seams) has one normal.
    keys = np.round(mesh.positions / 1e-9).astype(np.int64)
    _, group = np.unique(keys, axis=0, return_inverse=True)
    group = group.ravel()
    seam = np.bincount(group)[group] > 1
    assert seam.sum() >= 2 * (48 + 24)  # both seams are there, split
    for g in np.unique(group[seam]):
        n = mesh.normals[group == g]
        assert _angle_deg(n[:, None], n[None, :]).max() < 0.01
    # ...and every normal is close to the torus's own (a 48 x 24 facet approximation).
    centre = mesh.positions.copy()
    centre[:, 1] = 0
    centre = centre / np.linalg.norm(centre, axis=1, keepdims=True) * R
    analytic = mesh.positions - centre
    assert np.percentile(_angle_deg(mesh.normals, analytic), 95) < 1.0
    assert mesh.uvs.shape == (len(mesh.positions), 2)  # the file's own UVs kept (no re-atlas)


@pytest.mark.filterwarnings("ignore:.*re-atlasing")  # STL has no UVs: re-atlased, as it should
@pytest.mark.slow
def test_stl_style_triangles_are_smooth_and_cube_edges_stay_hard(tmp_path):
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.1)
    stl = tmp_path / "ball.stl"
    sphere.export(stl)  # STL stores every triangle's corners apart
    mesh = load_mesh(stl)
    outward = mesh.positions / np.linalg.norm(mesh.positions, axis=1, keepdims=True)
    assert np.percentile(_angle_deg(mesh.normals, outward), 99) < 2.0  # not faceted

    cube = trimesh.creation.box((0.1, 0.1, 0.1))
    box = tmp_path / "box.stl"
    cube.export(box)
    mesh = load_mesh(box)
    axes = np.eye(3)
    # 90-degree edges are above the crease angle: every normal is a face's axis.
    best = np.abs(mesh.normals @ axes.T).max(axis=1)
    assert CREASE_DEG < 90 and np.all(best > 1 - 1e-9)


@pytest.mark.parametrize("angle", [30.0, 75.0])
def test_crease_angle_decides_hard_or_smooth(angle):
    # Two triangles folded along the x axis by `angle` degrees: smooth below the crease angle.
    t = math.radians(angle)
    positions = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [0, math.sin(t), -math.cos(t)]])
    faces = np.array([[0, 2, 1], [0, 1, 3]])
    uvs = np.array([[0.5, 0.5], [0.9, 0.5], [0.5, 0.9], [0.5, 0.1]])  # no overlap
    mesh = mesh_from_triangles(positions, faces, uvs)
    at_edge = mesh.normals[
        np.isclose(mesh.positions[:, 2], 0) & np.isclose(mesh.positions[:, 1], 0)
    ]
    spread = _angle_deg(at_edge[:, None], at_edge[None, :]).max()
    if angle < CREASE_DEG:
        assert spread < 1e-3  # one averaged normal on the shared edge
    else:
        assert spread == pytest.approx(angle, abs=1e-3)  # each face keeps its own (float32)
