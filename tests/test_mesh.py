"""Meshes: unique UV atlases, right-handed tangent frames, the plate convention, file loading."""

import math
import warnings

import numpy as np
import pytest
import trimesh

from dentdemo.errors import DentdemoError
from dentdemo.mesh import primitives
from dentdemo.mesh.loader import check_uvs, load_mesh

PRIMITIVES = {
    "plate": lambda: primitives.plate(1.0),
    "box": lambda: primitives.box((0.4, 0.2, 0.1)),
    "sphere": lambda: primitives.sphere(0.1, 16),
    "capsule": lambda: primitives.capsule(0.05, 0.2, 32, 8),
    "cylinder": lambda: primitives.cylinder(0.05, 0.2, 32, 4),
}
AREAS = {
    "plate": 1.0,
    "box": 2 * (0.4 * 0.2 + 0.4 * 0.1 + 0.2 * 0.1),
    "sphere": 4 * math.pi * 0.01,
    "capsule": 4 * math.pi * 0.05**2 + 2 * math.pi * 0.05 * 0.2,
    "cylinder": 2 * math.pi * 0.05**2 + 2 * math.pi * 0.05 * 0.2,
}


@pytest.mark.parametrize("name", PRIMITIVES)
def test_primitive_has_unique_uvs_and_right_handed_frames(name):
    mesh = PRIMITIVES[name]()
    assert check_uvs(mesh.uvs, mesh.indices).ok
    assert mesh.surface_area() == pytest.approx(AREAS[name], rel=0.02)
    # Outward winding: face normals agree with vertex normals.
    a, b, c = mesh.triangle_corners()
    face = np.cross(b - a, c - a)
    assert np.all((face * mesh.normals[mesh.indices].sum(1)).sum(1) > 0)
    # (T, B, N) right-handed everywhere with B along +v.
    assert np.all(mesh.tangents[:, 3] == 1.0)
    assert np.allclose(np.linalg.norm(mesh.tangents[:, :3], axis=1), 1.0, atol=1e-5)
    assert np.abs((mesh.tangents[:, :3] * mesh.normals).sum(1)).max() < 1e-4


@pytest.mark.parametrize("name", ["box", "sphere", "capsule", "cylinder"])
def test_charts_keep_a_gutter_from_the_atlas_edge(name):
    mesh = PRIMITIVES[name]()
    assert mesh.uvs.min() >= primitives.GUTTER - 1e-6
    assert mesh.uvs.max() <= 1 - primitives.GUTTER + 1e-6


def test_plate_convention():
    mesh = primitives.plate(2.0)
    u, v = mesh.uvs[:, 0], mesh.uvs[:, 1]
    np.testing.assert_allclose(mesh.positions[:, 0], (u - 0.5) * 2.0, atol=1e-6)
    np.testing.assert_allclose(mesh.positions[:, 2], (0.5 - v) * 2.0, atol=1e-6)
    np.testing.assert_allclose(mesh.tangents[:, :3], np.tile([1, 0, 0], (len(u), 1)), atol=1e-6)
    sp = mesh.surface_at(np.array([0.3, 0.2, -0.4]))
    np.testing.assert_allclose(sp.uv, [0.65, 0.7])
    np.testing.assert_allclose(sp.dpdv, [0, 0, -2.0])
    assert sp.distance == pytest.approx(0.2)


def test_check_uvs_finds_tiled_and_overlapping():
    quad = np.array([[0, 1, 2], [0, 2, 3]])
    assert check_uvs(None, quad).missing
    assert check_uvs(np.array([[0, 0], [2, 0], [2, 2], [0, 2.0]]), quad).tiled
    # Two quads on the same uv square overlap.
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]] * 2)
    report = check_uvs(uv, np.vstack([quad, quad + 4]))
    assert report.overlapping and report.overlap_fraction > 0.9


def test_loaded_mesh_without_uvs_is_reatlased(tmp_path):
    path = tmp_path / "ball.obj"
    trimesh.creation.icosphere(subdivisions=2, radius=0.1).export(path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = load_mesh(path)
    assert any("re-atlasing" in str(w.message) for w in caught)
    assert check_uvs(mesh.uvs, mesh.indices).ok
    assert mesh.surface_area() == pytest.approx(4 * math.pi * 0.01, rel=0.05)


def test_loaded_mesh_with_tiled_uvs_is_reatlased(tmp_path):
    path = tmp_path / "quads.obj"
    path.write_text(
        "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 0 1 0\nv 1 1 0\n"
        "vt 0 0\nvt 3 0\nvt 3 3\nvt 0 3\n"
        "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\nf 1/1 2/2 6/3\nf 1/1 6/3 5/4\n"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh = load_mesh(path)
    assert check_uvs(mesh.uvs, mesh.indices).ok


def test_unreadable_mesh_is_a_clear_error(tmp_path):
    path = tmp_path / "broken.obj"
    path.write_text("this is not a mesh\n")
    with pytest.raises(DentdemoError, match="broken.obj"):
        load_mesh(path)
