"""The demo panel's typed values, checked before they reach the simulation: each is clamped to
the range a scene file allows for the same quantity (model/scene.py BOUNDS), and a value that is
not a number (NaN, text) is refused, the previous value kept. Pure functions: no window."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from dentdemo.model.scene import BOUNDS

#: The demo's time scale, x real time (no scene key: the demo's own bound; 0 stands still).
TIME_SCALE = (0.0, 4.0)

#: Each numeric panel field's range, in the units of the scene key for the same quantity.
PANEL_BOUNDS: dict[str, tuple[float, float]] = {
    "ball_radius": (BOUNDS.size_min, BOUNDS.size_max),  # m, as a sphere's radius
    "plate_side": (BOUNDS.size_min, BOUNDS.size_max),  # m, as a plate's side
    "throw_speed": (0.0, BOUNDS.speed),  # m/s, as a body's velocity
}


@dataclass
class PanelState:
    """What the control panel sets."""

    ball_material: str = "steel"
    ball_radius: float = 0.04  # m
    throw_speed: float = 6.0  # m/s
    plate_material: str = "aluminium"
    plate_side: float = 0.5  # m


def clamped(value: object, bounds: tuple[float, float], previous: float) -> float:
    """`value` as a float within `bounds` (infinities go to the nearer end); `previous` when
    it is not a number or NaN."""
    if isinstance(value, bool):
        return previous
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return previous
    if math.isnan(x):
        return previous
    low, high = bounds
    return min(max(x, low), high)


def panel_value(name: str, value: object, previous: float) -> float:
    """A typed value of the panel's numeric field `name` (PANEL_BOUNDS), clamped or refused."""
    return clamped(value, PANEL_BOUNDS[name], previous)


def checked(panel: PanelState) -> PanelState:
    """A copy of `panel` with every numeric field within its bounds (a field set around the
    setters, NaN included, falls back to the field's default)."""
    defaults = type(panel)()
    kept = dataclasses.replace(panel)
    for name in PANEL_BOUNDS:
        setattr(kept, name, panel_value(name, getattr(panel, name), getattr(defaults, name)))
    return kept


def on_panel(rect: tuple[float, float, float, float] | None, x: float, y: float) -> bool:
    """Whether the window point (x, y) (pixels from the top left) lies on the panel, whose
    rectangle is (left, top, width, height) in the same pixels (None: not drawn yet)."""
    if rect is None:
        return False
    left, top, width, height = rect
    return left <= x <= left + width and top <= y <= top + height
