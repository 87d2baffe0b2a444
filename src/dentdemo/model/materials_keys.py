"""The numeric keys of a materials file with their units and valid ranges: the one table that
start-up, hot reload, the demo's material editor and saved states (which name presets of a
library checked by it) read them from. Each range spans what real materials do, with room, and
stays inside what ODE and the carve hold; the reason is beside each."""

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
    #: An optional key's Material field (where its derived value is, for the editor).
    attribute: str = ""
    #: A bound that depends on another key, said in words ("< E": below youngs_modulus_Pa).
    also: str = ""
    #: Why the range is what it is (shown with a refusal).
    why: str = ""

    def read(self, reader: TableReader) -> float:
        """The key's value from `reader`'s table, checked against the range (or its default;
        an absent optional key without one is for the caller to check first)."""
        value = reader.number(self.key, self.default)
        low = -math.inf if self.low is None else self.low
        high = math.inf if self.high is None else self.high
        if value < low or (value == low and not self.low_inclusive):
            op = ">=" if self.low_inclusive else ">"
            raise reader.fail(self.key, f"must be {op} {low:g} ({self.explained()})")
        if value > high or (value == high and not self.high_inclusive):
            op = "<=" if self.high_inclusive else "<"
            raise reader.fail(self.key, f"must be {op} {high:g} ({self.explained()})")
        return value

    def explained(self) -> str:
        """The range with its unit and reason, e.g. "range [0.1, 1e+05] kg/m^3: ..."."""
        unit = "" if self.unit == "1" else f" {self.unit}"
        text = f"range {self.range_text()}{unit}"
        return f"{text}: {self.why}" if self.why else text

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


#: Every numeric key of a preset, in the order of the shipped file.
MATERIAL_NUMBERS: tuple[NumberKey, ...] = (
    NumberKey(
        "youngs_modulus_Pa",
        "Pa",
        low=1e4,
        high=1e13,
        why="soft gels and foams ~1e4 Pa to diamond 1.05e12 Pa",
    ),
    NumberKey(
        "yield_stress_Pa",
        "Pa",
        low=1e3,
        high=1e11,
        why="foams ~1e4 Pa to the strongest solids ~1e10 Pa; it documents the preset only",
    ),
    NumberKey(
        "plastic_modulus_Pa",
        "Pa",
        low=1e3,
        high=1e13,
        high_inclusive=False,
        also="< E",
        why="a tenth of the softest E and below E; k = C (1/P - 1/E) grows as 1/P",
    ),
    NumberKey(
        "density_kg_m3",
        "kg/m^3",
        low=0.1,
        high=1e5,
        # 1e200 overflowed a body's inertia and aborted ODE (dNormalize4); here a 100 m box
        # weighs at most 1e11 kg.
        why="aerogel ~1 to osmium 22590 kg/m^3, with room; ODE's inertia stays finite",
    ),
    NumberKey(
        "restitution",
        "1",
        low=0.0,
        high=1.0,
        high_inclusive=False,
        why="Y = 1/(1 - eps) - 1 (eq. 5) is infinite at 1",
    ),
    NumberKey(
        "friction",
        "1",
        low=0.0,
        high=10.0,
        why="Coulomb mu of real pairs 0.01 to ~2 (clean metals in vacuum more)",
    ),
    NumberKey(
        "max_dent_depth_m",
        "m",
        low=0.0,
        high=1.0,
        low_inclusive=False,
        why="a dent no deeper than a body's thickness; a height map holds it in float32",
    ),
    # Absent: derived from E and P (and checked against the same range).
    NumberKey(
        "k_m_per_Ns",
        "m/(N*s)",
        low=0.0,
        high=1e3,
        optional=True,
        # At 1e3, 1 mN*s above Y already dents 1 m, past any max_dent_depth_m: a larger k
        # changes no dent and only overflows k * j.
        why="clay's 3e-3 is the softest preset; 1e3 dents 1 m per mN*s",
        attribute="k",
    ),
    # Rolling resistance coefficient C_rr (force / normal force); absent: none.
    NumberKey(
        "rolling_friction",
        "1",
        low=0.0,
        high=1.0,
        default=0.0,
        why="steel on steel 0.001 to soft tyres on sand ~0.3",
    ),
    # Archard's wear coefficient K (V = K F s / H); absent: the body does not wear.
    NumberKey(
        "wear_coefficient",
        "1",
        low=0.0,
        high=1.0,
        default=0.0,
        why="lubricated pairs ~1e-9 to severe abrasion ~1e-1; K = 1 wears F s / H, all contact",
    ),
    # Indentation hardness H (Vickers or Brinell, kgf/mm^2 times 9.80665e6); absent: three
    # times the yield stress (Tabor's H ~ 3 Y for metals).
    NumberKey(
        "hardness_Pa",
        "Pa",
        low=1e3,
        high=3e11,
        optional=True,
        attribute="hardness",
        why="three times yield_stress_Pa's range (diamond is ~1e11 Pa); V = K F s / H grows as 1/H",
    ),
    NumberKey("metalness", "1", low=0.0, high=1.0, default=0.0, why="0 dielectric, 1 metal"),
    NumberKey(
        "roughness",
        "1",
        low=0.02,
        high=1.0,
        default=0.5,
        why="GGX perceptual roughness (alpha = r^2); polished metal ~0.05 to chalk 1",
    ),
    # A coat of paint (optional): where a dent or scratch goes deeper, the material shows.
    NumberKey(
        "coat_thickness_m",
        "m",
        low=0.0,
        high=0.01,
        default=0.0,
        why="0: no coat; car paint ~1e-4 m, a thick enamel ~1e-3 m",
    ),
    NumberKey(
        "coat_metalness", "1", low=0.0, high=1.0, default=0.0, why="0 dielectric (paint), 1 metal"
    ),
    # The coat's own wear (Archard's K and H, while a groove is within the coat); absent: the
    # material's own wear_coefficient and hardness.
    NumberKey(
        "coat_wear_coefficient",
        "1",
        low=0.0,
        high=1.0,
        optional=True,
        attribute="coat_wear_coefficient",
        why="as wear_coefficient's; acrylic on steel ~7e-6, 0: the coat never wears through",
    ),
    NumberKey(
        "coat_hardness_Pa",
        "Pa",
        low=1e3,
        high=3e11,
        optional=True,
        attribute="coat_hardness",
        why="as hardness_Pa's; paints and clear coats ~1e8 to 5e8 Pa",
    ),
    NumberKey(
        "coat_roughness",
        "1",
        low=0.02,
        high=1.0,
        default=0.5,
        why="GGX perceptual roughness of the coat; gloss paint ~0.2 to matte 1",
    ),
)

#: The same, by key.
NUMBER_KEYS: dict[str, NumberKey] = {k.key: k for k in MATERIAL_NUMBERS}

#: The numbers of `[calibration]`, each with its default.
CALIBRATION_NUMBERS: dict[str, NumberKey] = {
    k.key: k
    for k in (
        NumberKey(
            "k_per_compliance",
            "1/(m*s)",
            low=0.0,
            high=1e10,
            default=2.0e5,
            why="5e4 times the shipped 2e5; any derived k is checked against k_m_per_Ns's range",
        ),
        NumberKey(
            "Y_unit_Ns",
            "N*s",
            low=0.0,
            high=1e6,
            low_inclusive=False,
            default=1.0,
            why="the momentum of 1000 t at 1 m/s; a larger threshold leaves every scene undented",
        ),
    )
}
