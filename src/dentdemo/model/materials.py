"""Material presets (assets/materials.toml plus user files) and the constants derived from them.

Units: moduli and stresses in Pa, density in kg/m^3, depths in m, impulses in N*s,
k in m per N*s (paper eq. 4), Y in N*s (paper eq. 5).
"""

from __future__ import annotations

import math
import unicodedata
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dentdemo.errors import ConfigError
from dentdemo.model.materials_keys import CALIBRATION_NUMBERS, NUMBER_KEYS
from dentdemo.model.validate import TableReader, load_toml
from dentdemo.resources import assets_dir

DEFAULT_MATERIALS_FILE = "materials.toml"


@dataclass(frozen=True)
class Calibration:
    """Global constants that map the stress-strain model onto impulses."""

    #: k = k_per_compliance * (1/P - 1/E); units 1/(m*s), so that k is in m/(N*s).
    k_per_compliance: float = 2.0e5
    #: Y = Y_unit * (1/(1 - eps) - 1), in N*s.
    Y_unit: float = 1.0


#: Surface character the renderer adds procedurally (base colour and roughness detail).
SURFACES = ("plain", "brushed", "cast", "grain", "matte")


@dataclass(frozen=True)
class Appearance:
    """How a material looks under physically based shading (metallic-roughness)."""

    #: Linear RGB base colour (albedo of a dielectric, F0 of a metal), each in [0, 1].
    base_colour: tuple[float, float, float] = (0.5, 0.5, 0.5)
    #: 0 dielectric, 1 metal.
    metalness: float = NUMBER_KEYS["metalness"].default or 0.0
    #: Perceptual roughness (GGX alpha = roughness^2), in [0.02, 1].
    roughness: float = NUMBER_KEYS["roughness"].default or 0.5
    #: Procedural detail: one of SURFACES.
    surface: str = "plain"
    #: A coat of paint over the body, metres thick (0: none). Where a dent or a scratch is
    #: deeper than the coat (height < -coat_thickness) the material above shows; elsewhere the
    #: coat's own colour (linear RGB), metalness and roughness.
    coat_thickness: float = 0.0
    coat_colour: tuple[float, float, float] = (0.5, 0.5, 0.5)
    coat_metalness: float = 0.0
    coat_roughness: float = 0.5

    def coated(self, height: float) -> bool:
        """Whether the coat covers a texel of `height` metres (dents negative)."""
        return self.coat_thickness > 0.0 and height >= -self.coat_thickness


@dataclass(frozen=True)
class Material:
    """One material preset; every field in SI units."""

    name: str
    #: Young's modulus E, Pa.
    youngs_modulus: float
    #: Yield stress S_yield, Pa (documents the preset; the impulse model uses Y instead).
    yield_stress: float
    #: Plastic tangent modulus P, Pa, 0 < P < E.
    plastic_modulus: float
    #: Density, kg/m^3.
    density: float
    #: Coefficient of restitution eps in [0, 1).
    restitution: float
    #: Coulomb friction coefficient mu (ODE's mu), >= 0.
    friction: float
    #: Deepest dent the material's height map may hold, m.
    max_dent_depth: float
    #: Depth per impulse above threshold, m/(N*s) (paper eq. 4).
    k: float
    #: True when the preset set k itself instead of deriving it from (1/P - 1/E).
    k_explicit: bool
    #: Impulse threshold, N*s (paper eq. 5).
    Y: float
    #: Where the numbers come from.
    source: str
    #: Shading (optional keys of the file; defaults: grey, dielectric, half rough, plain).
    appearance: Appearance = Appearance()
    #: Rolling resistance coefficient C_rr (resisting force / normal force, dimensionless); the
    #: contact's torque limit is C_rr * N * the rolling radius (physics/world.py). 0: none.
    rolling_friction: float = 0.0
    #: Archard's wear coefficient K (dimensionless): V = K F s / H. 0: the body does not wear.
    wear_coefficient: float = 0.0
    #: Indentation hardness H, Pa (Archard's law divides by it).
    hardness: float = 1e9
    #: True when the preset set hardness_Pa; otherwise it is TABOR_FACTOR * yield_stress.
    hardness_explicit: bool = False
    #: The coat's own Archard K (dimensionless) and hardness (Pa), while a groove is within it;
    #: when the preset sets none, the material's own (the `_explicit` flags say which).
    coat_wear_coefficient: float = 0.0
    coat_hardness: float = 1e9
    coat_wear_explicit: bool = False
    coat_hardness_explicit: bool = False

    def coat_wear_ratio(self) -> float:
        """How much more the material wears than its coat for the same work, (K / H) / (K_coat /
        H_coat): 1 without a coat of its own law; inf for a coat that never wears through."""
        if self.appearance.coat_thickness <= 0.0:
            return 1.0
        base = self.wear_coefficient / self.hardness
        coat = self.coat_wear_coefficient / self.coat_hardness
        if coat <= 0.0:
            return math.inf if base > 0.0 else 1.0
        return base / coat

    def as_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "youngs_modulus_Pa": self.youngs_modulus,
            "yield_stress_Pa": self.yield_stress,
            "plastic_modulus_Pa": self.plastic_modulus,
            "density_kg_m3": self.density,
            "restitution": self.restitution,
            "friction": self.friction,
            "rolling_friction": self.rolling_friction,
            "wear_coefficient": self.wear_coefficient,
            "hardness_Pa": self.hardness,
            "hardness_explicit": self.hardness_explicit,
            "coat_wear_coefficient": self.coat_wear_coefficient,
            "coat_hardness_Pa": self.coat_hardness,
            "max_dent_depth_m": self.max_dent_depth,
            "k_m_per_Ns": self.k,
            "k_explicit": self.k_explicit,
            "Y_Ns": self.Y,
            "source": self.source,
            "base_colour": list(self.appearance.base_colour),
            "metalness": self.appearance.metalness,
            "roughness": self.appearance.roughness,
            "surface": self.appearance.surface,
            "coat_thickness_m": self.appearance.coat_thickness,
            "coat_colour": list(self.appearance.coat_colour),
            "coat_metalness": self.appearance.coat_metalness,
            "coat_roughness": self.appearance.coat_roughness,
        }


def threshold(restitution: float, y_unit: float = 1.0) -> float:
    """Paper eq. 5: Y = Y_unit * (1/(1 - eps) - 1), N*s; eps must lie in [0, 1)."""
    if not 0.0 <= restitution < 1.0:
        raise ValueError(f"restitution {restitution} outside [0, 1)")
    return y_unit * (1.0 / (1.0 - restitution) - 1.0)


def derived_k(youngs_modulus: float, plastic_modulus: float, k_per_compliance: float) -> float:
    """k = C * (1/P - 1/E), m/(N*s) (paper eq. 3 abstracted by one calibration constant C)."""
    return k_per_compliance * (1.0 / plastic_modulus - 1.0 / youngs_modulus)


@dataclass(frozen=True)
class MaterialLibrary:
    """The effective presets after the built-in file and any user files."""

    calibration: Calibration
    materials: dict[str, Material]
    sources: tuple[str, ...]
    #: How many presets each file in `sources` defines (adds or overrides), by path.
    defined: dict[str, int] = field(default_factory=dict)
    #: The presets each file in `sources` defines, by path.
    names_in: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def get(self, name: str, source: str = "materials", where: str = "") -> Material:
        """The preset `name`; an unknown name raises a ConfigError naming `source` and `where`."""
        try:
            return self.materials[name]
        except KeyError:
            known = ", ".join(sorted(self.materials))
            raise ConfigError(
                source, where, f"unknown material '{name}' (known: {known})"
            ) from None

    def names(self) -> list[str]:
        return sorted(self.materials)


def builtin_materials_path() -> Path:
    return assets_dir() / DEFAULT_MATERIALS_FILE


def load_materials(user_files: list[Path] | tuple[Path, ...] = ()) -> MaterialLibrary:
    """Load the built-in presets, then each user file in order (adding or overriding presets)."""
    raw_tables: dict[str, tuple[str, dict[str, Any]]] = {}
    calibration_raw: tuple[str, dict[str, Any]] | None = None
    files = [builtin_materials_path(), *[Path(p) for p in user_files]]
    defined: dict[str, int] = {}
    names_in: dict[str, tuple[str, ...]] = {}
    for path in files:
        data = load_toml(path)
        source = str(path)
        for key in data:
            if key not in ("calibration", "materials"):
                raise ConfigError(
                    source, f"[{key}]", "unknown table (expected [calibration] or [materials.NAME])"
                )
        if "calibration" in data:
            calibration_raw = (source, data["calibration"])
        materials = data.get("materials", {})
        if not isinstance(materials, dict):
            raise ConfigError(source, "[materials]", "must be a table of tables")
        defined[source] = len(materials)
        names_in[source] = tuple(materials)
        for name, table in materials.items():
            check_preset_name(source, name)
            raw_tables[name] = (source, table)
    calibration = _parse_calibration(*calibration_raw) if calibration_raw else Calibration()
    parsed = {
        name: _parse_material(src, name, tbl, calibration)
        for name, (src, tbl) in raw_tables.items()
    }
    if not parsed:
        raise ConfigError(str(files[-1]), "", "no materials defined")
    return MaterialLibrary(calibration, parsed, tuple(str(p) for p in files), defined, names_in)


#: The longest preset name, characters (the panel's and the editor's combo boxes show it whole).
NAME_MAX = 64


def check_preset_name(source: str, name: str) -> None:
    """A preset name a panel shows as it is read: 1 to NAME_MAX characters, none of them a
    control or formatting character (a right-to-left override would show another name than
    the file holds), no leading or trailing space."""
    bad = [c for c in name if unicodedata.category(c) in ("Cc", "Cf", "Cs", "Co", "Zl", "Zp")]
    if bad or not 0 < len(name) <= NAME_MAX or name != name.strip():
        why = f"holds {ascii(bad[0])[1:-1]}" if bad else "is empty, too long or space-padded"
        raise ConfigError(
            source,
            f"[materials.{ascii(name)}]",
            f"a preset name must be 1 to {NAME_MAX} printable characters; this one {why}",
        )


def reloaded_line(before: MaterialLibrary, after: MaterialLibrary, path: str) -> str:
    """What a hot reload of `path` says: how many presets it defines now and, where it no
    longer defines some it did, which (they are back to the earlier files' values or gone)."""
    line = f"dentdemo: reloaded {path} ({after.defined.get(path, 0)} materials)"
    dropped = [n for n in before.names_in.get(path, ()) if n not in after.names_in.get(path, ())]
    if dropped:
        shown = ", ".join(dropped[:4]) + (", ..." if len(dropped) > 4 else "")
        line += f"; it no longer sets {shown}: built-in or earlier files' values, where any"
    return line


def _parse_calibration(source: str, table: Any) -> Calibration:
    reader = TableReader(source, "calibration", table)
    calibration = Calibration(
        k_per_compliance=CALIBRATION_NUMBERS["k_per_compliance"].read(reader),
        Y_unit=CALIBRATION_NUMBERS["Y_unit_Ns"].read(reader),
    )
    reader.finish()
    return calibration


def parse_material(source: str, name: str, table: Any, calibration: Calibration) -> Material:
    """One `[materials.NAME]` table checked as a file's is (a ConfigError names `source`)."""
    return _parse_material(source, name, table, calibration)


def material_table(material: Material) -> dict[str, Any]:
    """The preset as its `[materials.NAME]` table would spell it (k only when set explicitly):
    `parse_material` of it gives the preset back."""
    look = material.appearance
    table: dict[str, Any] = {
        "youngs_modulus_Pa": material.youngs_modulus,
        "yield_stress_Pa": material.yield_stress,
        "plastic_modulus_Pa": material.plastic_modulus,
        "density_kg_m3": material.density,
        "restitution": material.restitution,
        "friction": material.friction,
        "rolling_friction": material.rolling_friction,
        "max_dent_depth_m": material.max_dent_depth,
    }
    if material.k_explicit:
        table["k_m_per_Ns"] = material.k
    table["wear_coefficient"] = material.wear_coefficient
    if material.hardness_explicit:
        table["hardness_Pa"] = material.hardness
    if material.coat_wear_explicit:
        table["coat_wear_coefficient"] = material.coat_wear_coefficient
    if material.coat_hardness_explicit:
        table["coat_hardness_Pa"] = material.coat_hardness
    table.update(
        source=material.source,
        base_colour=list(look.base_colour),
        metalness=look.metalness,
        roughness=look.roughness,
        surface=look.surface,
    )
    if look.coat_thickness > 0.0:
        table.update(
            coat_thickness_m=look.coat_thickness,
            coat_colour=list(look.coat_colour),
            coat_metalness=look.coat_metalness,
            coat_roughness=look.coat_roughness,
        )
    return table


def _parse_material(source: str, name: str, table: Any, calibration: Calibration) -> Material:
    reader = TableReader(source, f"materials.{name}", table)
    number = {key: spec.read(reader) for key, spec in NUMBER_KEYS.items() if not spec.optional}
    youngs, plastic = number["youngs_modulus_Pa"], number["plastic_modulus_Pa"]
    if plastic >= youngs:
        raise reader.fail("plastic_modulus_Pa", f"must be below youngs_modulus_Pa ({youngs:g})")
    if reader.has("k_m_per_Ns"):
        k = NUMBER_KEYS["k_m_per_Ns"].read(reader)
        explicit = True
    else:
        k = derived_k(youngs, plastic, calibration.k_per_compliance)
        explicit = False
    k_range = NUMBER_KEYS["k_m_per_Ns"]
    if not explicit and not (math.isfinite(k) and k <= (k_range.high or math.inf)):
        raise reader.fail(
            "plastic_modulus_Pa",
            f"gives k = k_per_compliance (1/P - 1/E) = {k:.3g} m/(N*s), outside k_m_per_Ns's "
            f"{k_range.explained()}",
        )
    hardness, hardness_explicit = _hardness(reader, number["yield_stress_Pa"])
    coat_k, coat_h = (
        NUMBER_KEYS[key].read(reader) if reader.has(key) else None
        for key in ("coat_wear_coefficient", "coat_hardness_Pa")
    )
    source_text = reader.string("source", "")
    default = Appearance()
    colour = _colour(reader, "base_colour", default.base_colour)
    appearance = Appearance(
        base_colour=colour,
        metalness=number["metalness"],
        roughness=number["roughness"],
        surface=reader.string("surface", default.surface, choices=SURFACES),
        coat_thickness=number["coat_thickness_m"],
        coat_colour=_colour(reader, "coat_colour", default.coat_colour),
        coat_metalness=number["coat_metalness"],
        coat_roughness=number["coat_roughness"],
    )
    reader.finish()
    return Material(
        name=name,
        youngs_modulus=youngs,
        yield_stress=number["yield_stress_Pa"],
        plastic_modulus=plastic,
        density=number["density_kg_m3"],
        restitution=number["restitution"],
        friction=number["friction"],
        max_dent_depth=number["max_dent_depth_m"],
        k=k,
        k_explicit=explicit,
        Y=threshold(number["restitution"], calibration.Y_unit),
        source=source_text,
        appearance=appearance,
        rolling_friction=number["rolling_friction"],
        wear_coefficient=number["wear_coefficient"],
        hardness=hardness,
        hardness_explicit=hardness_explicit,
        coat_wear_coefficient=number["wear_coefficient"] if coat_k is None else coat_k,
        coat_hardness=hardness if coat_h is None else coat_h,
        coat_wear_explicit=coat_k is not None,
        coat_hardness_explicit=coat_h is not None,
    )


def _colour(
    reader: TableReader, key: str, default: tuple[float, float, float]
) -> tuple[float, float, float]:
    """A linear RGB colour key, each component in [0, 1]."""
    colour = reader.vec3(key, default)
    if not all(0.0 <= c <= 1.0 for c in colour):
        raise reader.fail(key, "each component must lie in [0, 1] (linear RGB)")
    return colour


#: Tabor's constraint factor: a metal's indentation hardness is about three times its yield
#: stress (Tabor, The Hardness of Metals, 1951), the hardness of a preset that sets none.
TABOR_FACTOR = 3.0


def _hardness(reader: TableReader, yield_stress: float) -> tuple[float, bool]:
    """hardness_Pa as the preset sets it, or TABOR_FACTOR times its yield stress; whether set."""
    spec = NUMBER_KEYS["hardness_Pa"]
    if reader.has(spec.key):
        return spec.read(reader), True
    derived = TABOR_FACTOR * yield_stress
    if not (spec.low or 0.0) <= derived <= (spec.high or math.inf):
        raise reader.fail(
            "yield_stress_Pa",
            f"gives hardness_Pa = 3 x yield = {derived:.3g} Pa, outside hardness_Pa's "
            f"{spec.explained()}; set hardness_Pa",
        )
    return derived, False
