"""The numeric keys of a material preset with their units and valid ranges: the one place the
validator (materials.py) and the demo's material editor read them from."""

from __future__ import annotations

import math
from dataclasses import dataclass

from dentdemo.model.validate import TableReader


@dataclass(frozen=True)
class NumberKey:
    """One number of a `[materials.NAME]` table: its key (the unit is in its name), the unit
    spelled out, its range and, for an optional key, its default."""

    key: str
    unit: str
    low: float | None = None
    high: float | None = None
    low_inclusive: bool = True
    high_inclusive: bool = True
    #: What an absent key means; None: the key is required (unless `optional`).
    default: float | None = None
    #: An absent key is derived from others (k from E and P) rather than defaulted.
    optional: bool = False
    #: A bound that depends on another key, said in words ("< E": below youngs_modulus_Pa).
    also: str = ""

    def read(self, reader: TableReader) -> float:
        """The key's value from `reader`'s table, checked against the range (or its default;
        an absent optional key without one is for the caller to check first)."""
        return reader.number(
            self.key,
            self.default,
            min_value=self.low,
            max_value=self.high,
            min_inclusive=self.low_inclusive,
            max_inclusive=self.high_inclusive,
        )

    def range_text(self) -> str:
        """The valid range as an interval, e.g. "[0, 1)" or "(0, inf)"."""
        low = "-inf" if self.low is None else f"{self.low:g}"
        high = "inf" if self.high is None else f"{self.high:g}"
        left = "[" if self.low is not None and self.low_inclusive else "("
        right = "]" if self.high is not None and self.high_inclusive else ")"
        text = f"{left}{low}, {high}{right}"
        return f"{text}, {self.also}" if self.also else text

    def clamp(self, value: float) -> float:
        """`value` moved into the closed range (an editor's widget limits; the open ends are
        left to the validator's message)."""
        low = -math.inf if self.low is None else self.low
        high = math.inf if self.high is None else self.high
        return min(max(value, low), high)


def _positive(key: str, unit: str, also: str = "") -> NumberKey:
    return NumberKey(key, unit, low=0.0, low_inclusive=False, also=also)


#: Every numeric key of a preset, in the order of the shipped file.
MATERIAL_NUMBERS: tuple[NumberKey, ...] = (
    _positive("youngs_modulus_Pa", "Pa"),
    _positive("yield_stress_Pa", "Pa"),
    _positive("plastic_modulus_Pa", "Pa", also="< E"),
    _positive("density_kg_m3", "kg/m^3"),
    NumberKey("restitution", "1", low=0.0, high=1.0, high_inclusive=False),
    NumberKey("friction", "1", low=0.0, high=10.0),
    NumberKey("max_dent_depth_m", "m", low=0.0, high=1.0, low_inclusive=False),
    NumberKey("k_m_per_Ns", "m/(N*s)", low=0.0, optional=True),  # absent: derived from E and P
    # Rolling resistance coefficient C_rr (force / normal force); absent: none.
    NumberKey("rolling_friction", "1", low=0.0, high=1.0, default=0.0),
    NumberKey("metalness", "1", low=0.0, high=1.0, default=0.0),
    NumberKey("roughness", "1", low=0.02, high=1.0, default=0.5),
)

#: The same, by key.
NUMBER_KEYS: dict[str, NumberKey] = {k.key: k for k in MATERIAL_NUMBERS}
