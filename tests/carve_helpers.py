"""Helpers shared by the carve tests: presses on the session context, analytic oracles."""

from __future__ import annotations

import numpy as np

from dentdemo.app.press import PressSetup, make_setup, shape_from_args

#: Presses made and not yet released; conftest's autouse fixture releases them after every test,
#: passed or failed, so one failure does not leak GPU objects into the next tests.
_LIVE: list[PressSetup] = []


def setup(
    gl,
    target="plate",
    target_size=(1.0,),
    tool="sphere",
    tool_size=(0.05,),
    map_size=512,
    tool_map_size=256,
    offset=(0.0, 0.0),
    direction=(0.0, -1.0, 0.0),
    max_dent_depth=0.1,
    tool_height=None,
) -> PressSetup:
    made = make_setup(
        gl,
        shape_from_args(target, list(target_size), "target"),
        shape_from_args(tool, list(tool_size), "tool"),
        map_size,
        tool_map_size,
        offset,
        np.asarray(direction, dtype=np.float64),
        max_dent_depth,
        tool_height,
    )
    _LIVE.append(made)
    return made


def release(s: PressSetup) -> None:
    if any(live is s for live in _LIVE):
        _LIVE.remove(s)
        for body in (s.target, s.tool):
            body.maps.release()
            body.gpu_mesh.release()


def release_all() -> int:
    """Release every press still alive; how many there were."""
    count = len(_LIVE)
    while _LIVE:
        release(_LIVE[-1])
    return count


def heights(gl, body) -> np.ndarray:
    return gl.read(body.maps.height)[:, :, 0]


def plate_xz(shape, side: float):
    """World x and z of every texel centre of a plate map (DESIGN.md convention)."""
    rows, cols = shape
    u = (np.arange(cols) + 0.5) / cols
    v = (np.arange(rows) + 0.5) / rows
    return (u[None, :] - 0.5) * side + 0 * v[:, None], (0.5 - v[:, None]) * side + 0 * u[None, :]


def cap(shape, side, centre, radius, depth):
    x, z = plate_xz(shape, side)
    r2 = (x - centre[0]) ** 2 + (z - centre[1]) ** 2
    h = -depth + radius - np.sqrt(np.maximum(radius**2 - r2, 0.0))
    return np.where(r2 < radius**2, np.minimum(h, 0.0), 0.0)
