"""Paper eqs. 2, 4, 5 against hand-computed values; the shapes' own checks and volumes."""

import numpy as np
import pytest

from dentdemo.model.impulse import dent_depth, normal_impulse, pair_impulses
from dentdemo.model.materials import derived_k, threshold
from dentdemo.model.shapes import (
    Box,
    Capsule,
    Cylinder,
    MeshFile,
    Plate,
    Sphere,
    mesh_volume,
)

UP = np.array([0.0, 1.0, 0.0])


def test_head_on_two_dynamic_bodies():
    # A (2 kg) at rest below, B (1 kg) falling onto it at 3 m/s; N from A to B is +Y.
    # j = (1 + 0.5) * 3 / (1/2 + 1/1) = 4.5 / 1.5 = 3 N*s; j_{eps=1} = 6 / 1.5 = 4 N*s.
    j, j1 = pair_impulses(UP, [0, 0, 0], [0, -3, 0], 0.5, 1.0, 0.5, 0.7)
    assert j == pytest.approx(3.0)
    assert j1 == pytest.approx(4.0)


def test_static_body_has_zero_inverse_mass():
    # Ball of 0.5 kg hitting a static plate at 4 m/s: j = (1 + 0.2) * 4 / 2 = 2.4 N*s.
    j, j1 = pair_impulses(UP, [0, 0, 0], [0, -4, 0], 0.0, 2.0, 0.2, 0.9)
    assert j == pytest.approx(2.4)
    assert j1 == pytest.approx(4.0)


def test_eps_zero_and_near_one():
    assert normal_impulse(UP, [0, 0, 0], [0, -2, 0], 0.0, 1.0, 0.0) == pytest.approx(2.0)
    assert normal_impulse(UP, [0, 0, 0], [0, -2, 0], 0.0, 1.0, 0.999) == pytest.approx(3.998)


def test_zero_and_separating_velocity_give_no_impulse():
    assert normal_impulse(UP, [0, 0, 0], [0, 0, 0], 1.0, 1.0, 0.5) == 0.0
    assert normal_impulse(UP, [0, 0, 0], [0, 2, 0], 1.0, 1.0, 0.5) == 0.0
    # Tangential motion only: no normal impulse.
    assert normal_impulse(UP, [0, 0, 0], [5, 0, 0], 1.0, 1.0, 0.5) == 0.0
    # Two static bodies: no impulse and no division by zero.
    assert normal_impulse(UP, [0, 0, 0], [0, -1, 0], 0.0, 0.0, 0.5) == 0.0


def test_oblique_uses_normal_component_only():
    n = np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0)
    j = normal_impulse(n, [0, 0, 0], [0, -2, 0], 0.0, 1.0, 1.0)
    assert j == pytest.approx(2.0 * 2.0 / np.sqrt(2.0))


def test_vectorised_over_many_impacts():
    normals = np.tile(UP, (4, 1))
    vb = np.array([[0, -1, 0], [0, -2, 0], [0, 1, 0], [0, -4, 0]], float)
    j = normal_impulse(normals, np.zeros((4, 3)), vb, np.zeros(4), np.ones(4), np.zeros(4))
    np.testing.assert_allclose(j, [1, 2, 0, 4])


def test_threshold_eq5():
    assert threshold(0.0) == 0.0
    assert threshold(0.5) == pytest.approx(1.0)
    assert threshold(0.75, y_unit=2.0) == pytest.approx(6.0)
    assert threshold(0.999) == pytest.approx(999.0)
    with pytest.raises(ValueError):
        threshold(1.0)


def test_dent_depth_eq4_and_clamp():
    # Below threshold: nothing; above: k * (j - Y); far above: the material bound.
    assert dent_depth(1.0, 1e-3, 1.5, 0.01) == 0.0
    assert dent_depth(3.5, 1e-3, 1.5, 0.01) == pytest.approx(2e-3)
    assert dent_depth(-3.5, 1e-3, 1.5, 0.01) == pytest.approx(2e-3)
    assert dent_depth(1e6, 1e-3, 1.5, 0.01) == pytest.approx(0.01)
    np.testing.assert_allclose(dent_depth([0.0, 2.5, 100.0], 1e-3, 1.5, 0.05), [0, 1e-3, 0.05])


def test_derived_k():
    # 2e5 * (1/2e9 - 1/200e9) = 2e5 * (5e-10 - 5e-12) = 9.9e-5, by hand.
    assert derived_k(200e9, 2e9, 2e5) == pytest.approx(9.9e-5, rel=1e-12)
    # E -> infinity (rigid elastic part): k = 2e5 / 1e9 = 2e-4.
    assert derived_k(1e300, 1e9, 2e5) == pytest.approx(2e-4, rel=1e-12)


# -- the shape vocabulary ----------------------------------------------------------------------
@pytest.mark.parametrize(
    ("make", "fragment"),
    [
        (lambda: Sphere(-1), "Sphere radius must be a positive finite number of metres, got -1"),
        (lambda: Sphere(0.0), "Sphere radius"),
        (lambda: Sphere(float("nan")), "got nan"),
        (lambda: Sphere("0.1"), "got '0.1'"),
        (lambda: Sphere(True), "got True"),
        (lambda: Box((0.1, 0.1)), "Box size must be 3 positive finite edge lengths"),
        (lambda: Box((0.1, 0.1, -0.1)), "got (0.1, 0.1, -0.1)"),
        (lambda: Box((0.1, 0.1, float("inf"))), "got (0.1, 0.1, inf)"),
        (lambda: Box(0.1), "got 0.1"),
        (lambda: Capsule(0.1, 0.0), "Capsule length must be a positive finite number"),
        (lambda: Capsule(-0.1, 0.2), "Capsule radius"),
        (lambda: Cylinder(0.1, float("inf")), "Cylinder length"),
        (lambda: Cylinder(0.0, 0.2), "Cylinder radius"),
        (lambda: Plate(-1.0), "Plate side"),
        (lambda: Plate(1.0, 0.0), "Plate thickness"),
        (lambda: MeshFile("m.obj", 0.0), "MeshFile scale must be a positive finite number"),
        (lambda: MeshFile("", 1.0), "MeshFile path"),
    ],
)
def test_a_shape_with_a_bad_size_is_a_clear_error(make, fragment):
    with pytest.raises(ValueError) as info:
        make()
    assert fragment in str(info.value)


def test_good_shapes_keep_their_sizes_as_floats():
    assert Box([1, 2, 3]).size == (1.0, 2.0, 3.0)
    assert Box(np.array([0.1, 0.2, 0.3])).volume() == pytest.approx(0.006)
    assert Sphere(np.float32(0.5)).radius == 0.5 and type(Sphere(1).radius) is float


def _cube() -> tuple[np.ndarray, np.ndarray]:
    """A 1 m cube, outward faces, as 8 corners and 12 triangles."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return corners, np.array(faces)


def test_mesh_volume_of_a_closed_an_open_and_a_flat_mesh():
    corners, faces = _cube()
    # Closed: 1 m^3 wherever the mesh lies (it is taken about the mesh's own centre).
    volume, open_share = mesh_volume(corners + 5.0, faces)
    assert volume == pytest.approx(1.0) and open_share == pytest.approx(0.0, abs=1e-12)
    # Inside out: -1 m^3.
    assert mesh_volume(corners, faces[:, ::-1])[0] == pytest.approx(-1.0)
    # Without its top face (y = 1, triangles 6-7): 1 m^2 of 5 m^2 is open.
    top = [i for i, f in enumerate(faces) if corners[f][:, 1].min() == 1]
    assert len(top) == 2
    assert mesh_volume(corners, np.delete(faces, top, axis=0))[1] == pytest.approx(0.2)
    # A flat sheet 0.3 m above its origin: all open, however much "volume" its cone holds.
    sheet = np.array([[0, 0.3, 0], [1, 0.3, 0], [1, 0.3, -1], [0, 0.3, -1]], float)
    assert mesh_volume(sheet, np.array([[0, 1, 2], [0, 2, 3]]))[1] == pytest.approx(1.0)
