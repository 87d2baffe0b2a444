"""The planning's small linear algebra against its definition: a matrix times its inverse is the
identity, for poses (rotation times a uniform scale) and for general 3 x 3 matrices."""

from __future__ import annotations

import numpy as np
import pytest

from dentdemo.carve.footprint import Rect, _faces_extreme
from dentdemo.carve.linear import inverse3


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else q[:, ::-1]  # a rotation, not a reflection


@pytest.mark.parametrize("seed", range(6))
def test_inverse_times_matrix_is_the_identity(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for m in (_rotation(rng) * rng.uniform(1e-3, 1e3), rng.normal(size=(3, 3))):
        inv = inverse3(m)
        assert np.allclose(inv @ m, np.eye(3), atol=1e-9)
        assert np.allclose(m @ inv, np.eye(3), atol=1e-9)


def test_a_singular_matrix_is_refused() -> None:
    with pytest.raises(ValueError):
        inverse3(np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 0.0]]))
    with pytest.raises(ValueError):
        inverse3(np.full((3, 3), np.nan))


def test_lowest_point_of_a_tilted_face_inside_a_rectangle() -> None:
    # A square face z = s = 0.5 x over x, y in [-1, 1]: within x in [-0.4, 0.2] its lowest s
    # is at x = -0.4 (s = -0.2) and its highest at x = 0.2 (s = 0.1); outside the face, none.
    corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    face = np.array([[[x, y, 0.5 * x] for x, y in corners]], dtype=np.float64)
    rect = Rect(-0.4, 0.2, -3.0, 3.0)
    assert _faces_extreme(face, rect, lowest=True) == pytest.approx(-0.2)
    assert _faces_extreme(face, rect, lowest=False) == pytest.approx(0.1)
    assert _faces_extreme(face, Rect(1.5, 2.0, 0.0, 0.5), lowest=True) is None


@pytest.mark.parametrize("seed", range(4))
def test_determinant_and_scale_of_a_pose(seed: int) -> None:
    # A rotation times a scale k has determinant k^3 and columns of length k; a mirror flips
    # the determinant's sign only.
    from dentdemo.carve.linear import column_scale, determinant3

    rng = np.random.default_rng(seed)
    k = rng.uniform(1e-2, 1e2)
    pose = _rotation(rng) * k
    assert determinant3(pose) == pytest.approx(k**3, rel=1e-12)
    assert column_scale(pose) == pytest.approx(k, rel=1e-12)
    mirrored = pose @ np.diag([-1.0, 1.0, 1.0])
    assert determinant3(mirrored) == pytest.approx(-(k**3), rel=1e-12)
    assert column_scale(mirrored) == pytest.approx(k, rel=1e-12)


@pytest.mark.parametrize("mirror", [1.0, -1.0])
@pytest.mark.parametrize("tilt", [0.0, 0.7, 1.4])
def test_a_plate_s_top_faces_the_camera_above_it_and_its_bottom_turns_away(mirror, tilt) -> None:
    # A 1 m plate tilted by `tilt` about x, seen along minus its top's normal: the top faces
    # the camera (its outward normal has s = -1), the bottom faces away, at any pose. Mirrored
    # across its own x, the posed windings turn over, and the faces follow them (as GL's
    # culling, which passes 2 and 3 use, does): the top then turns away.
    from dentdemo.carve.footprint import Projected
    from dentdemo.mesh.primitives import box

    plate = box((1.0, 0.02, 1.0))
    c, s = np.cos(tilt), np.sin(tilt)
    rotation = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    model = np.eye(4)
    model[:3, :3] = rotation @ np.diag([mirror, 1.0, 1.0]) * 2.0
    model[:3, 3] = (0.3, -0.2, 0.5)
    top = rotation @ np.array([0.0, 1.0, 0.0])
    forward = -top
    right = np.array([1.0, 0.0, 0.0])
    axes = np.stack([right, np.cross(right, forward), forward])
    projected = Projected(plate, model, model[:3, 3] + top, axes)
    # The box's faces by their outward (vertex) normals: +y the top, -y the bottom.
    normal_y = plate.normals[plate.indices[:, 0], 1]
    top_faces, bottom_faces = np.flatnonzero(normal_y > 0.5), np.flatnonzero(normal_y < -0.5)
    towards, away = (top_faces, bottom_faces) if mirror > 0 else (bottom_faces, top_faces)
    assert projected.faces_away(towards, away=False)
    assert not projected.faces_away(towards, away=True)
    assert projected.faces_away(away, away=True)
    assert not projected.faces_away(away, away=False)


def test_the_extent_of_a_face_cut_by_a_slab() -> None:
    # A square face s = 0.5 x over x, y in [-1, 1] (two triangles), cut by 0 <= s <= 0.25:
    # the part with 0 <= x <= 0.5, all y. Above or below it: nothing. Inside it whole: itself.
    from dentdemo.carve.footprint import _faces_slab_rect

    corners = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    square = [[float(x), float(y), 0.5 * x] for x, y in corners]
    faces = [[square[0], square[1], square[2]], [square[0], square[2], square[3]]]
    rect = _faces_slab_rect(faces, 0.0, 0.25)
    assert rect is not None
    assert (rect.x0, rect.x1, rect.y0, rect.y1) == pytest.approx((0.0, 0.5, -1.0, 1.0))
    assert _faces_slab_rect(faces, 0.6, 0.9) is None
    assert _faces_slab_rect(faces, -0.7, -0.6) is None
    whole = _faces_slab_rect(faces, -1.0, 1.0)
    assert whole is not None and (whole.x0, whole.x1, whole.y0, whole.y1) == (-1, 1, -1, 1)


@pytest.mark.parametrize("seed", range(5))
def test_the_faces_slab_extent_equals_the_meshes_one(seed: int) -> None:
    # The Python-float path for a built-in shape's few faces and the numpy path for a mesh's
    # triangles take the same points, so they give the same extent to the bit.
    from dentdemo.carve.footprint import _faces_slab_rect, slab_rect

    rng = np.random.default_rng(seed)
    tris = rng.normal(size=(12, 3, 3))
    for lo, hi in ((-0.3, 0.4), (0.5, 0.6), (-5.0, 5.0), (2.0, 3.0)):
        a, b = _faces_slab_rect(tris.tolist(), lo, hi), slab_rect(tris, lo, hi)
        assert (a is None) == (b is None)
        if a is not None and b is not None:
            assert (a.x0, a.x1, a.y0, a.y1) == (b.x0, b.x1, b.y0, b.y1)


@pytest.mark.parametrize("mirror", [1.0, -1.0])
@pytest.mark.parametrize("seed", range(4))
def test_a_box_s_nearest_and_farthest_points_come_from_its_corners(seed: int, mirror) -> None:
    # A box seen whole (a rectangle around all of it) has its lowest and highest s at corners:
    # the extremes of its eight corners' s, at any pose, mirrored or not (s_extreme looks at the
    # faces turned towards, or away from, the camera only). Seen through a rectangle around one
    # corner's x, y alone, the lowest s is no lower than that corner's if it is the nearest.
    from dentdemo.carve.footprint import Projected
    from dentdemo.mesh.primitives import box

    rng = np.random.default_rng(seed)
    size = rng.uniform(0.05, 1.0, 3)
    solid = box(tuple(size))
    model = np.eye(4)
    model[:3, :3] = _rotation(rng) @ np.diag([mirror, 1.0, 1.0]) * rng.uniform(0.5, 2.0)
    model[:3, 3] = rng.normal(size=3)
    forward = _rotation(rng)[:, 0]
    right = np.cross(forward, rng.normal(size=3))
    right /= np.linalg.norm(right)
    axes = np.stack([right, np.cross(right, forward), forward])
    origin = rng.normal(size=3)
    projected = Projected(solid, model, origin, axes)
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    corners = (signs * size / 2) @ model[:3, :3].T + model[:3, 3]
    camera = (corners - origin) @ axes.T  # (8, 3): x, y, s
    whole = Rect(-1e3, 1e3, -1e3, 1e3)
    assert projected.s_extreme(whole, lowest=True) == pytest.approx(camera[:, 2].min())
    assert projected.s_extreme(whole, lowest=False) == pytest.approx(camera[:, 2].max())
    nearest = camera[np.argmin(camera[:, 2])]
    around = Rect(nearest[0] - 1e-6, nearest[0] + 1e-6, nearest[1] - 1e-6, nearest[1] + 1e-6)
    assert projected.s_extreme(around, lowest=True) == pytest.approx(nearest[2], abs=1e-5)


def _matrix(data: bytes) -> np.ndarray:
    """A GLSL mat3 or mat4 from column-major float32 bytes, as the shader reads it."""
    values = np.frombuffer(data, dtype=np.float32).astype(np.float64)
    n = int(round(len(values) ** 0.5))
    return values.reshape(n, n, order="F")


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("mirror", [False, True])
def test_pose_uniforms_are_the_pose_its_normal_matrix_and_its_inverse(seed: int, mirror) -> None:
    """What the carve's shaders read of a posed body, against numpy's own inverse: the pose
    (world from local), the normal matrix (the inverse transposed), a swept solid's local frame
    (local from world) and its ends and radius in world metres, for every built-in shape."""
    from dentdemo.carve.texel_passes import pose_uniforms
    from dentdemo.mesh import primitives

    rng = np.random.default_rng(seed)
    linear = _rotation(rng) * rng.uniform(0.2, 5.0)
    if mirror:
        linear = linear @ np.diag([1.0, 1.0, -1.0])
    model = np.eye(4)
    model[:3, :3], model[:3, 3] = linear, rng.normal(size=3)
    inverse = np.linalg.inv(linear)
    scale = abs(np.linalg.det(linear)) ** (1 / 3)
    meshes = {
        "sphere": primitives.sphere(0.05, subdivisions=6),
        "capsule": primitives.capsule(0.02, 0.1, around=16, rings=4),
        "cylinder": primitives.cylinder(0.02, 0.1, around=16),
        "plate": primitives.plate(0.5, thickness=0.02),
        "box": primitives.box((0.1, 0.2, 0.3)),
    }
    for name, mesh in meshes.items():
        u = pose_uniforms(mesh, model)
        assert np.allclose(_matrix(u["u_model"]), model, rtol=1e-6, atol=1e-6), name
        assert np.allclose(_matrix(u["u_normal_matrix"]), inverse.T, rtol=1e-6, atol=1e-6), name
        swept = name in ("sphere", "capsule")  # the shapes that are their own swept sphere
        assert u["u_swept"] is swept, name
        assert u.get("u_quad", 0) == {"sphere": 1, "capsule": 2}.get(name, 0), name
        if swept:
            assert np.allclose(_matrix(u["u_swept_local"]), inverse, rtol=1e-6, atol=1e-6)
            radius = {"sphere": 0.05, "capsule": 0.02}[name]
            assert u["u_swept_radius"] == pytest.approx(radius * scale, rel=1e-12)
            half = 0.0 if name == "sphere" else 0.05  # the capsule's axis: local z
            for key, z in (("u_swept_a", -half), ("u_swept_b", half)):
                end = linear @ np.array([0.0, 0.0, z]) + model[:3, 3]
                assert np.allclose(u[key], end, atol=1e-12), (name, key)
