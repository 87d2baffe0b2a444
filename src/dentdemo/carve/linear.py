"""3 x 3 linear algebra on Python floats, for the few small matrices and vectors a hit's
planning works with: on such sizes numpy's general routines cost several times these in call
overhead alone."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

#: A 3-vector as Python floats (any sequence of three is accepted where one is read).
Floats3 = tuple[float, float, float]


def dot3(a: Sequence[float], b: Sequence[float]) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross3(a: Sequence[float], b: Sequence[float]) -> Floats3:
    return a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]


def rows_times(rows: Sequence[Sequence[float]], v: Sequence[float]) -> Floats3:
    """A 3 x 3 matrix (its rows) times a vector."""
    return dot3(rows[0], v), dot3(rows[1], v), dot3(rows[2], v)


def inverse3(m: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of the 3 x 3 matrix `m` (the linear part of a pose), by cofactors.
    A singular `m` raises ValueError (a pose always has a non-zero scale)."""
    return np.array(inverse_rows(m.tolist()))


def inverse_rows(m: Sequence[Sequence[Any]]) -> tuple[tuple[Any, Any, Any], ...]:
    """`inverse3` of a matrix given as its rows, of Python floats or of arrays of them
    (carve/lanes.py: each array one entry of many matrices, inverted together with the same
    bits). A singular matrix (any, of arrays) raises ValueError."""
    (a, b, c), (d, e, f), (g, h, i) = m
    ei_fh, fg_di, dh_eg = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * ei_fh + b * fg_di + c * dh_eg
    singular = (det == 0.0) | (det != det)
    if singular.any() if isinstance(singular, np.ndarray) else singular:
        raise ValueError("singular 3x3 matrix")
    r = 1.0 / det
    return (
        (ei_fh * r, (c * h - b * i) * r, (b * f - c * e) * r),
        (fg_di * r, (a * i - c * g) * r, (c * d - a * f) * r),
        (dh_eg * r, (b * g - a * h) * r, (a * e - b * d) * r),
    )


def determinant3(m: NDArray[np.float64]) -> float:
    """The determinant of the 3 x 3 matrix `m`."""
    (a, b, c), (d, e, f), (g, h, i) = m.tolist()
    return a * (e * i - f * h) + b * (f * g - d * i) + c * (d * h - e * g)


def column_scale(m: NDArray[np.float64]) -> float:
    """The largest length of the 3 x 3 matrix `m`'s columns (a pose's scale)."""
    (a, b, c), (d, e, f), (g, h, i) = m.tolist()
    return max(a * a + d * d + g * g, b * b + e * e + h * h, c * c + f * f + i * i) ** 0.5
