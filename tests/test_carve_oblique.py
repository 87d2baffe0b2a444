"""What `depth` means for a press that is not along the surface normal (issue 19, item 4): the
tool moves `depth` metres along the press direction, and every surface point inside the solid it
sweeps moves inwards along its own normal until it leaves that solid. Oracle: the swept ball is a
capsule, and the depth under each plate point is where the vertical line through the point
leaves it, worked out here from the spheres along the sweep."""

from __future__ import annotations

import math

import numpy as np
import pytest

import dentdemo
from surface_helpers import DENTED

RADIUS, DEPTH, SIDE, SIZE = 0.02, 0.003, 0.1, 1024


def swept_ball_depth(
    x: np.ndarray, z: np.ndarray, start: np.ndarray, end: np.ndarray, radius: float = RADIUS
) -> np.ndarray:
    """How far below y = 0 a ball of `radius` swept from `start` to `end` (centres) reaches under
    each (x, z): the lowest point of any of its positions, 0 where it does not reach."""
    deepest = np.zeros_like(x)
    for f in np.linspace(0.0, 1.0, 601):
        c = start + f * (end - start)
        r2 = radius**2 - (x - c[0]) ** 2 - (z - c[2]) ** 2
        bottom = np.where(r2 > 0, c[1] - np.sqrt(np.maximum(r2, 0.0)), np.inf)
        deepest = np.maximum(deepest, -bottom)
    return deepest


@pytest.mark.parametrize("degrees", [0.0, 20.0, 30.0, 45.0])
@pytest.mark.slow
def test_an_oblique_press_dents_to_the_swept_ball(gl, degrees):
    ctx = gl.ctx
    plate = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Plate(SIDE)), SIZE)
    ball = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Sphere(RADIUS)), 64)
    start = np.array([0.0, RADIUS, 0.0])  # touching the plate at the origin
    ball.model = np.eye(4)
    ball.model[:3, 3] = start
    t = math.radians(degrees)
    direction = np.array([math.sin(t), -math.cos(t), 0.0])
    carver = dentdemo.Carver(ctx)
    try:
        assert carver.press(plate, ball, dentdemo.Contact((0, 0, 0), direction), DEPTH)
        h = plate.heights().astype(np.float64)
    finally:
        for thing in (carver, ball, plate):
            thing.release()
    # The plate's texel centres (x = (u - 0.5) SIDE, z = (0.5 - v) SIDE) in a window that holds
    # the dent (the sweep moves the ball at most DEPTH; its footprint is under 2 RADIUS wide).
    c = (np.arange(SIZE) + 0.5) / SIZE
    near = np.abs((c - 0.5) * SIDE) < RADIUS
    x = ((c - 0.5) * SIDE)[None, near]
    z = ((0.5 - c) * SIDE)[near, None]
    x, z = np.broadcast_arrays(x, z)
    h = h[np.ix_(near, near)]
    expected = -swept_ball_depth(x, z, start, start + DEPTH * direction)
    # The deepest point: the ball's lowest point moved DEPTH cos(t) down.
    assert -h.min() == pytest.approx(DEPTH * math.cos(t), rel=0.01)
    assert -expected.min() == pytest.approx(DEPTH * math.cos(t), rel=1e-3)
    # Texel by texel, away from the rim (where a texel straddles the edge of the dent).
    inner = expected < -0.1 * DEPTH
    error = np.abs(h[inner] - expected[inner])
    assert float(error.max()) < 0.02 * DEPTH, float(error.max())
    # Nothing is dented beyond the rim by more than the tool's own sampling: the camera's pixel
    # is one of the ball's texels (64 a quarter turn: about 0.5 mm, five plate texels), and the
    # swept ball's depth is interpolated between pixels.
    stray = (h < DENTED) & (expected > -1e-6) & _far_from(expected, 2)
    assert float(-h[stray].min(initial=0.0)) < 0.1 * DEPTH
    assert not ((h < DENTED) & _far_from(expected, 15)).any()  # three camera pixels


def _far_from(expected: np.ndarray, texels: int) -> np.ndarray:
    """Texels more than `texels` from any texel the oracle dents."""
    dent = expected < 0
    near = dent.copy()
    for _ in range(texels):
        grown = near.copy()
        grown[1:] |= near[:-1]
        grown[:-1] |= near[1:]
        grown[:, 1:] |= near[:, :-1]
        grown[:, :-1] |= near[:, 1:]
        near = grown
    return ~near
