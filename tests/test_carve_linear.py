"""The planning's small linear algebra against its definition: a matrix times its inverse is the
identity, for poses (rotation times a uniform scale) and for general 3 x 3 matrices."""

from __future__ import annotations

import numpy as np
import pytest

from dentdemo.carve.footprint import Rect, _faces_extreme
from dentdemo.carve.linear import inverse3


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


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
