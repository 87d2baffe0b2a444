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


def _directions(count: int, seed: int) -> np.ndarray:
    """Unit directions: random ones, and ones on and beside the cube's edges and corners."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(count, 3))
    edges = np.array([[1, 1, 0], [1, 0, -1], [0, -1, 1], [1, 1, 1], [-1, 1, -1], [-1, -1, -1]])
    d = np.vstack([d, edges, edges + rng.normal(scale=1e-6, size=edges.shape)])
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("n", [1, 5, 12, 48])
@pytest.mark.slow
def test_a_spheres_frame_is_the_triangle_under_the_point(n):
    # Oracle: the triangle that the ray from the centre along the point's direction crosses
    # (its barycentric coordinates all >= 0, from solving the ray-plane system), and the uv of
    # the point's projection on that triangle's plane (its barycentric coordinates from the
    # corners). The nearest bounding-sphere centre, which the frame used to follow, is another
    # triangle for most directions.
    radius = 0.04
    mesh = primitives.sphere(radius, n)
    corners = mesh.positions.astype(np.float64)[mesh.indices]  # (m, 3, 3)
    uvs = mesh.uvs.astype(np.float64)[mesh.indices]
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    for d in _directions(300, n):
        point = radius * d
        frame = mesh.frame_near(point)
        # t d = a + b1 e1 + b2 e2 for every triangle at once, by Cramer's rule.
        pe2 = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, pe2)
        det = np.where(np.abs(det) < 1e-300, np.nan, det)  # parallel: never crossed
        s_ = -corners[:, 0]
        b1 = np.einsum("ij,ij->i", s_, pe2) / det
        qe1 = np.cross(s_, e1)
        b2 = (qe1 @ d) / det
        t = np.einsum("ij,ij->i", e2, qe1) / det
        hit = (t > 0) & (b1 >= -1e-6) & (b2 >= -1e-6) & (b1 + b2 <= 1 + 1e-6)
        crossed = np.flatnonzero(hit)  # one, or the triangles beside an edge or corner crossed
        dpdu, dpdv = mesh.triangle_derivatives(crossed)
        chosen = [
            k
            for k, a, b in zip(crossed, dpdu, dpdv, strict=True)
            if np.allclose(frame.dpdu, a, rtol=0, atol=1e-12)
            and np.allclose(frame.dpdv, b, rtol=0, atol=1e-12)
        ]
        assert chosen, (d, crossed, frame)
        k = chosen[0]
        normal = np.cross(e1[k], e2[k])
        normal /= np.linalg.norm(normal)
        q = point - ((point - corners[k, 0]) @ normal) * normal - corners[k, 0]
        g = np.array([[e1[k] @ e1[k], e1[k] @ e2[k]], [e1[k] @ e2[k], e2[k] @ e2[k]]])
        c1, c2 = np.linalg.solve(g, [q @ e1[k], q @ e2[k]])
        uv = uvs[k, 0] + c1 * (uvs[k, 1] - uvs[k, 0]) + c2 * (uvs[k, 2] - uvs[k, 0])
        assert np.abs(frame.uv - uv).max() <= 1e-9


def test_a_kept_triangle_frame_gives_what_a_fresh_mesh_gives(monkeypatch):
    # `frame_near` keeps each triangle's frame (at most FRAMES_KEPT): points asked in any
    # order, many over one triangle and the cache cleared on the way, get the same bits as
    # from a fresh copy of the mesh asked for that point alone; a caller that changes the
    # normal it was given changes no later frame.
    from dentdemo.mesh import mesh as mesh_module

    monkeypatch.setattr(mesh_module, "FRAMES_KEPT", 5)
    radius = 0.03
    rng = np.random.default_rng(11)
    directions = _directions(40, 11)
    points = radius * np.vstack([directions, directions[rng.permutation(len(directions))]])
    for make in (lambda: primitives.sphere(radius, 4), lambda: primitives.plate(0.5, 3)):
        mesh = make()
        for point in points:
            fresh = make().frame_near(point)
            kept = mesh.frame_near(point)
            for field in ("uv", "dpdu", "dpdv", "normal"):
                assert np.array_equal(getattr(kept, field), getattr(fresh, field)), field
            assert kept.distance == fresh.distance
            kept.normal[:] = np.nan  # the caller's copy
        assert len(mesh._triangle_frame_cache[1]) <= 5


def test_a_plates_frame_is_its_own_uv_everywhere():
    # The plate convention (x = (u - 0.5) S, z = (0.5 - v) S): any point's uv and one frame,
    # dP/du = (S, 0, 0) and dP/dv = (0, 0, -S), whatever triangle it lies over.
    side = 0.7
    mesh = primitives.plate(side, subdivisions=6)
    rng = np.random.default_rng(3)
    for x, y, z in rng.uniform([-0.4, -0.01, -0.4], [0.4, 0.01, 0.4], size=(50, 3)) * [
        side / 0.8,
        1.0,
        side / 0.8,
    ]:
        frame = mesh.frame_near(np.array([x, y, z]))
        assert np.allclose(frame.uv, [x / side + 0.5, 0.5 - z / side], rtol=0, atol=1e-6)
        assert np.allclose(frame.dpdu, [side, 0, 0], rtol=0, atol=1e-6)
        assert np.allclose(frame.dpdv, [0, 0, -side], rtol=0, atol=1e-6)
        assert np.allclose(frame.normal, [0, 1, 0]) and abs(frame.distance - abs(y)) <= 1e-9
