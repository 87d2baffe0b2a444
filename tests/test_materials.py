"""Material presets: the built-in file, user overrides, and every kind of bad input."""

import json
import tomllib
from pathlib import Path

import pytest

from cli_helpers import dentdemo
from dentdemo.errors import ConfigError
from dentdemo.model.materials import load_materials
from scene_text import TIN

ROOT = Path(__file__).resolve().parents[1]

GOOD = "\n" + TIN


def test_builtin_presets_cover_the_range():
    lib = load_materials()
    assert len(lib.materials) >= 8
    for name in ("steel", "aluminium", "copper", "brass", "lead", "oak", "clay", "rubber"):
        m = lib.get(name)
        assert 0 <= m.restitution < 1
        assert m.plastic_modulus < m.youngs_modulus
        assert m.source
    # Eqs. 4 and 5 with the shipped calibration, worked by hand:
    # steel: k = 2e5 * (1/2e9 - 1/200e9) = 2e5 * 4.95e-10 = 9.9e-5 m/(N s); Y = 1/(1-0.6)-1 = 1.5
    # aluminium: k = 2e5 * (1/0.7e9 - 1/69e9) = 2.8282e-4 m/(N s); Y = 1/(1-0.5)-1 = 1.0
    assert lib.get("steel").k == pytest.approx(9.9e-5, rel=1e-9)
    assert lib.get("steel").Y == pytest.approx(1.5, rel=1e-12)
    assert lib.get("aluminium").k == pytest.approx(2.82816e-4, rel=1e-5)
    assert lib.get("aluminium").Y == pytest.approx(1.0, rel=1e-12)
    # Soft metals dent more per impulse than hard ones; rubber barely at all.
    assert lib.get("lead").k > lib.get("aluminium").k > lib.get("steel").k > lib.get("rubber").k


def test_user_file_adds_and_overrides(tmp_toml):
    path = tmp_toml(
        GOOD + "\n[materials.steel]\nyoungs_modulus_Pa = 210e9\nyield_stress_Pa = 355e6\n"
        "plastic_modulus_Pa = 2e9\ndensity_kg_m3 = 7850\nrestitution = 0.7\nfriction = 0.5\n"
        "max_dent_depth_m = 0.005\nk_m_per_Ns = 3e-5\n"
    )
    lib = load_materials([path])
    assert lib.get("tin").density == 7300
    steel = lib.get("steel")
    assert steel.k == 3e-5 and steel.k_explicit
    assert steel.Y == pytest.approx(1 / 0.3 - 1)


BAD_CASES = [
    ("[materials.x\n", "malformed TOML"),
    (
        GOOD.replace("restitution = 0.3", "restitution = 1.0"),
        "key 'restitution' = 1.0: must be < 1",
    ),
    (
        GOOD.replace("restitution = 0.3", "restitution = -0.1"),
        "key 'restitution' = -0.1: must be >= 0",
    ),
    (
        GOOD.replace("density_kg_m3 = 7300", "density_kg_m3 = 0"),
        "key 'density_kg_m3' = 0: must be >= 0.1 (range [0.1, 100000] kg/m^3",
    ),
    (
        GOOD.replace("density_kg_m3 = 7300", "density_kg_m3 = nan"),
        "key 'density_kg_m3' = nan: must be finite",
    ),
    (GOOD.replace("density_kg_m3 = 7300", "density_kg_m3 = inf"), "must be finite"),
    (GOOD.replace("density_kg_m3 = 7300", 'density_kg_m3 = "heavy"'), "must be a number"),
    (GOOD.replace("density_kg_m3 = 7300", "density_kg_m3 = true"), "must be a number"),
    (
        GOOD.replace("plastic_modulus_Pa = 0.5e9", "plastic_modulus_Pa = 60e9"),
        "key 'plastic_modulus_Pa' = 60000000000.0: must be below youngs_modulus_Pa",
    ),
    (GOOD.replace("friction = 0.5", "frcition = 0.5"), "missing key 'friction'"),
    (GOOD + "colour = 1\n", "key 'colour' = 1: unknown key"),
    (GOOD.replace("max_dent_depth_m = 0.02", "max_dent_depth_m = -0.02"), "max_dent_depth_m"),
    (GOOD + "k_m_per_Ns = -1\n", "key 'k_m_per_Ns' = -1: must be >= 0"),
    ("[metals]\nx = 1\n", "[metals]: unknown table"),
    ("materials = 3\n", "[materials]: must be a table"),
    ("[calibration]\nY_unit_Ns = 0\n", "key 'Y_unit_Ns' = 0: must be > 0"),
]


@pytest.mark.parametrize("text,expected", BAD_CASES)
def test_bad_files_name_file_table_and_key(tmp_toml, text, expected):
    path = tmp_toml(text)
    with pytest.raises(ConfigError) as info:
        load_materials([path])
    message = str(info.value)
    assert str(path) in message
    assert expected in message
    assert "\n" not in message
    if "key '" in expected:
        assert "[materials.tin]" in message or "[calibration]" in message


def test_missing_file_and_unknown_material(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        load_materials([tmp_path / "absent.toml"])
    with pytest.raises(ConfigError, match="unknown material 'unobtainium'"):
        load_materials().get("unobtainium", "scene.toml", "[body.ball]")


def _cli(*args):
    return dentdemo(*args)


def test_cli_materials_json_lists_every_preset_with_k_and_y():
    """k and Y of every preset computed here from the file's own numbers (read with tomllib),
    by the formulas the file states (eqs. 4-5), and steel's worked by hand."""
    result = _cli("materials", "--json")
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    raw = tomllib.loads((ROOT / "assets" / "materials.toml").read_text())
    per_compliance = raw["calibration"]["k_per_compliance"]
    y_unit = raw["calibration"]["Y_unit_Ns"]
    assert sorted(m["name"] for m in data["materials"]) == sorted(raw["materials"])
    for entry in data["materials"]:
        preset = raw["materials"][entry["name"]]
        k = preset.get("k_m_per_Ns")
        if k is None:
            k = per_compliance * (
                1 / preset["plastic_modulus_Pa"] - 1 / preset["youngs_modulus_Pa"]
            )
        y = y_unit * (1 / (1 - preset["restitution"]) - 1)
        assert entry["k_m_per_Ns"] == pytest.approx(k, rel=1e-12), entry["name"]
        assert entry["Y_Ns"] == pytest.approx(y, rel=1e-12), entry["name"]
    steel = next(m for m in data["materials"] if m["name"] == "steel")
    # 2e5 (1/2e9 - 1/200e9) = 9.9e-5 m/(N s); 1/(1 - 0.6) - 1 = 1.5 N s.
    assert steel["k_m_per_Ns"] == pytest.approx(9.9e-5, rel=1e-12)
    assert steel["Y_Ns"] == pytest.approx(1.5, rel=1e-12)


def test_cli_bad_file_exits_nonzero_with_one_line(tmp_toml):
    path = tmp_toml(GOOD.replace("restitution = 0.3", "restitution = 2"))
    result = _cli("materials", "--materials", str(path))
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1
    assert str(path) in lines[0] and "[materials.tin]" in lines[0] and "'restitution'" in lines[0]
    assert "Traceback" not in result.stderr


def test_cli_version():
    result = _cli("--version")
    assert result.returncode == 0 and result.stdout.startswith("dentdemo ")
