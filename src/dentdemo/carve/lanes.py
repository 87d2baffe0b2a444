"""Lanes: pass 1's per-direction arithmetic written once, for one direction on Python floats
and for a batch's directions on numpy arrays. A lane is one quantity of the directions being
worked out: a Python float where they are worked out one by one (`ONE`), an (n,) float64
array where together (`ARRAY`: one array expression per step). The same expressions give the
same bits either way: IEEE arithmetic in the same order, and a mode's `greater`, `lesser` and
`where` pick as Python's max, min and conditional expression do (of two equal values, 0.0 and
-0.0, the first). Vectors are tuples of three lanes; `carve.linear`'s 3-vector products take
them too."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numpy as np

from dentdemo.carve.linear import dot3

#: A float, or an (n,) float64 array: one value of each direction (typed loosely: numpy's
#: operators and Python's give a lane either way).
Lane = Any
#: A vector of lanes.
Lanes3 = tuple[Lane, Lane, Lane]


class Mode(NamedTuple):
    """How lanes are made and compared: `ONE` (Python floats, one direction) or `ARRAY`."""

    #: The lane of the directions' values.
    lane: Callable[[list[float]], Lane]
    #: Python's max(a, b) and min(a, b), lane by lane.
    greater: Callable[[Lane, Lane], Lane]
    lesser: Callable[[Lane, Lane], Lane]
    #: `a if condition else b`, lane by lane.
    where: Callable[[Lane, Lane, Lane], Lane]
    floor: Callable[[Lane], Lane]
    ceil: Callable[[Lane], Lane]
    sqrt: Callable[[Lane], Lane]
    #: Whether a condition holds for any direction.
    any_of: Callable[[Lane], bool]

    def columns(self, rows: Sequence[Sequence[float]]) -> tuple[Lane, ...]:
        """Each column of `rows` (a row a direction) as a lane."""
        if self is ONE:
            (row,) = rows
            return tuple(row)
        return tuple(self.lane(list(column)) for column in zip(*rows, strict=True))

    def rows(self, lanes: Sequence[Lane]) -> list[tuple[float, ...]]:
        """Each direction's values of `lanes`: `columns` undone."""
        if self is ONE:
            return [tuple(lanes)]
        return list(zip(*(x.tolist() for x in lanes), strict=True))

    def unit(self, v: Sequence[Lane]) -> Lanes3:
        k = 1.0 / self.greater(self.sqrt(dot3(v, v)), 1e-30)
        return v[0] * k, v[1] * k, v[2] * k


def _one(values: list[float]) -> Lane:
    return values[0]


def _array(values: list[float]) -> Lane:
    return np.array(values, dtype=np.float64)


def _where(condition: Lane, a: Lane, b: Lane) -> Lane:
    return a if condition else b


ONE = Mode(_one, max, min, _where, math.floor, math.ceil, math.sqrt, bool)
ARRAY = Mode(
    _array,
    lambda a, b: np.where(b > a, b, a),
    lambda a, b: np.where(b < a, b, a),
    np.where,
    np.floor,
    np.ceil,
    np.sqrt,
    lambda condition: bool(np.any(condition)),
)


def across(v: Sequence[Lane], direction: Sequence[Lane]) -> Lanes3:
    """`v` less its part along the unit vector `direction`."""
    along = dot3(v, direction)
    return v[0] - along * direction[0], v[1] - along * direction[1], v[2] - along * direction[2]
