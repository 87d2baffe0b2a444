"""The panel's material editor without the panel: a draft of one preset's table, checked by the
materials file's own validator at every edit, and the dent a throw would leave, predicted in
closed form (paper eqs. 2-5) before any throw."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from dentdemo.errors import DentdemoError
from dentdemo.model.impulse import dent_depth, normal_impulse
from dentdemo.model.materials import Material, MaterialLibrary, material_table, parse_material

#: Where a draft's errors say they come from.
EDITOR_SOURCE = "material editor"


@dataclass(frozen=True)
class PredictedDent:
    """A ball thrown straight down onto a static plate: the dent in each, metres."""

    plate_material: str
    plate_m: float
    ball_m: float
    #: The impulse eq. 2 gives with eps = 1 (what eq. 4 dents by), N*s.
    j_elastic: float
    #: Whether a dent is its bound, the material's max_dent_depth_m or the body's thickness
    #: (eq. 4 asked for more).
    plate_bound: bool = False
    ball_bound: bool = False


def predict_dent(
    ball: Material, radius: float, speed: float, plate: Material, plate_thickness: float = math.inf
) -> PredictedDent:
    """A solid ball of `radius` (m) and `ball`'s density hitting a static plate along its normal
    at `speed` (m/s): eq. 2 with eps = 1 and 1/m_plate = 0 gives |j| = 2 m v; eq. 4 (with eq. 3's
    k and eq. 5's Y of each material, and its bound) gives each body's dent, never deeper than
    the body is thick (the plate's `plate_thickness`, the ball's 2 r: mesh/thickness.py)."""
    mass = ball.density * 4.0 / 3.0 * math.pi * radius**3  # kg
    # The plate is body A (static), the ball B coming down onto it; N points from A to B.
    j1 = float(normal_impulse((0.0, 1.0, 0.0), (0.0, 0.0, 0.0), (0.0, -speed, 0.0), 0, 1 / mass, 1))
    plate_bound = min(plate.max_dent_depth, plate_thickness)
    ball_bound = min(ball.max_dent_depth, 2.0 * radius)
    plate_m = float(dent_depth(j1, plate.k, plate.Y, plate_bound))
    ball_m = float(dent_depth(j1, ball.k, ball.Y, ball_bound))
    return PredictedDent(
        plate.name, plate_m, ball_m, j1, plate_m >= plate_bound, ball_m >= ball_bound
    )


class MaterialEditor:
    """One preset's table being edited. `preset` is the last valid state of the draft (what the
    demo uses); `error` the validator's one line while the draft is invalid, else empty."""

    def __init__(self, library: MaterialLibrary, name: str) -> None:
        self.library = library
        self.select(library, name)

    def select(self, library: MaterialLibrary, name: str) -> None:
        """Edit `name` of `library` (afresh: the draft is the preset as it is there)."""
        self.library = library
        self.name = name
        self.preset: Material = library.materials[name]
        self.draft: dict[str, Any] = material_table(self.preset)
        self.error = ""

    def set(self, key: str, value: Any) -> Material | None:
        """Change one key of the draft (None removes an optional one: k is then derived); the
        preset it makes, or None and `error` when the validator refuses it."""
        if value is None:
            self.draft.pop(key, None)
        else:
            self.draft[key] = list(value) if isinstance(value, tuple) else value
        try:
            preset = parse_material(EDITOR_SOURCE, self.name, self.draft, self.library.calibration)
        except DentdemoError as exc:
            self.error = str(exc).splitlines()[0]
            return None
        self.error = ""
        self.preset = preset
        return preset


def with_preset(library: MaterialLibrary, preset: Material) -> MaterialLibrary:
    """`library` with `preset` in place of the one of its name."""
    materials = {**library.materials, preset.name: preset}
    return MaterialLibrary(
        library.calibration, materials, library.sources, library.defined, library.names_in
    )
