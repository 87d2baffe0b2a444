"""Paper eqs. 2, 4, 5 against hand-computed values."""

import numpy as np
import pytest

from dentdemo.model.impulse import dent_depth, normal_impulse, pair_impulses
from dentdemo.model.materials import derived_k, threshold

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
