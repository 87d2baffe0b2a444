"""Scratches (issue 44): Archard's wear law and the groove a dragged tool leaves, held to oracles of
their own: the circle's segment and cap by numerical integration, Archard's volume by hand from
the shipped presets' K and H, the groove's cross-section against the tool's circle, and a rolling
tool's zero wear."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from cli_helpers import dentdemo
from dentdemo.model import wear


def _circle_groove_area(radius: float, depth: float, n: int = 200_001) -> float:
    """The area a circle pressed `depth` down sweeps below the surface, by the midpoint rule
    across it: at x its lowest point is d - (R - sqrt(R^2 - x^2)) deep (independent of the
    closed form)."""
    x = (np.arange(n) + 0.5) / n * 2 * radius - radius
    deep = depth - (radius - np.sqrt(radius**2 - x**2))
    return float(np.maximum(deep, 0.0).sum() * 2 * radius / n)


@pytest.mark.parametrize("depth", [1e-7, 3e-4, 0.004, 0.01, 0.017, 0.05])
def test_segment_area_is_the_circles_and_its_depth_inverts_it(depth):
    r = 0.01
    area = wear.segment_area(r, depth)
    assert area == pytest.approx(_circle_groove_area(r, depth), rel=1e-6)
    assert wear.sphere_groove_depth(r, area) == pytest.approx(depth, rel=1e-9)


def test_segment_area_at_half_and_whole_disc():
    r = 0.02
    assert wear.segment_area(r, r) == pytest.approx(math.pi * r * r / 2, rel=1e-12)
    # Past its equator the circle sweeps a slot as wide as itself.
    assert wear.segment_area(r, 2 * r) == pytest.approx(math.pi * r * r / 2 + 2 * r * r)
    assert wear.sphere_groove_depth(r, 0.0) == 0.0


@pytest.mark.parametrize("d", [0.003, 0.01, 0.014])
def test_cap_volume_is_the_integral_of_its_discs(d):
    """The print of a sphere pressed d: discs of radius^2 r^2 - (r - d + y)^2, or r^2 once the
    sphere's equator has passed (y below the surface, from its deepest point)."""
    r, n = 0.01, 100_000
    y = (np.arange(n) + 0.5) / n * d
    centre = np.maximum(r - y, 0.0)  # how far above the sphere's centre the disc lies
    discs = math.pi * (r * r - centre**2)
    assert wear.cap_volume(r, d) == pytest.approx(float(discs.sum() * d / n), rel=1e-6)


def test_archard_volume_and_rolling():
    # 0.5 N*m slid against 1 GPa with K = 1e-3: 5e-13 m^3 by hand.
    assert wear.archard_volume(1e-3, 10.0, 0.05, 1e9) == pytest.approx(5e-13, rel=1e-12)
    assert wear.archard_volume(1e-3, 10.0, 0.0, 1e9) == 0.0
    with pytest.raises(ValueError, match="hardness"):
        wear.archard_volume(1e-3, 10.0, 1.0, 0.0)


def _scratch(gl, tool, material_name, load, distance, map_size, heading=0.0, slip=1.0):
    from dentdemo.app.scratch import Drag, carve_groove, groove_for, make_scratch, target_for
    from dentdemo.model.materials import load_materials

    material = load_materials().get(material_name)
    drag = Drag(load, distance, 1.0, slip)
    plate = target_for("plate", drag, groove_for(tool, material, drag), tool)
    setup = make_scratch(gl, plate, tool, material, drag, map_size, math.radians(heading))
    try:
        carve_groove(gl, setup)
        height = gl.read(setup.target.maps.height)[:, :, 0].astype(np.float64)
    finally:
        setup.release()
    return material, plate, setup, height


def _texel_coordinates(height, side, heading):
    """Each texel's distance along a path centred on the plate along `heading` from its start
    (at -distance/2) and across it, m, measured from the middle (plate: x = (u - 1/2) side,
    z = (1/2 - v) side)."""
    rows, cols = height.shape
    x = ((np.arange(cols) + 0.5) / cols - 0.5)[None, :] * side
    z = (0.5 - (np.arange(rows) + 0.5) / rows)[:, None] * side
    c, s = math.cos(math.radians(heading)), math.sin(math.radians(heading))
    return x * c + z * s, -x * s + z * c


@pytest.mark.parametrize(
    "heading,map_size",
    [(0.0, 512), (30.0, 512), (-72.0, 2048)],  # 2048: three segments meet along the path
)
@pytest.mark.slow
def test_a_dragged_sphere_wears_archards_volume_on_the_shipped_steel(gl, heading, map_size):
    """A 10 mm ball pressed with 5 kN along 50 mm of the shipped steel preset: the groove holds
    K F s / H (K, H of the preset, by hand) plus the two half caps at its ends, within 5 %; its
    cross-section along the straight part is the ball's circle at one depth, whose segment
    times the path is Archard's volume."""
    from dentdemo.model.shapes import Sphere

    r, load, distance = 0.01, 5000.0, 0.05
    steel, plate, setup, height = _scratch(
        gl, Sphere(r), "steel", load, distance, map_size, heading
    )
    volume = steel.wear_coefficient * load * distance / steel.hardness
    assert volume == pytest.approx(7e-3 * 5000 * 0.05 / 1.18e9)  # the preset's K and H
    texel = plate.side / map_size
    measured = -height.sum() * texel * texel
    # The depth from the test's own inversion of the midpoint-rule area (no closed form).
    lo, hi = 0.0, r
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if _circle_groove_area(r, mid, 20001) * distance < volume else (lo, mid)
    depth = (lo + hi) / 2
    caps = math.pi * depth**2 * (3 * r - depth) / 3
    assert measured == pytest.approx(volume + caps, rel=0.05)
    along, off = _texel_coordinates(height, plate.side, heading)
    half = math.sqrt(2 * r * depth - depth**2)
    straight = (np.abs(along) < distance / 2 - 2 * half) & (np.abs(off) < half + 2 * texel)
    expected = np.maximum(depth - (r - np.sqrt(np.maximum(r * r - off**2, 0.0))), 0.0)
    error = np.abs(-height[straight] - expected[straight])
    assert error.max() < 0.03 * depth, error.max() / depth
    # Nothing grooved beyond the path's capsule.
    ends = np.maximum(np.abs(along) - distance / 2, 0.0)
    assert not (height[np.hypot(ends, off) > half + 1.5 * texel] < 0).any()
    # The straight part's volume per metre is the segment's area, A(d) = V / s.
    middle = np.abs(along) < distance / 4
    per_metre = -height[middle].sum() * texel * texel / (distance / 2)
    assert per_metre == pytest.approx(volume / distance, rel=0.03)


def test_a_dragged_box_cuts_a_flat_groove(gl):
    """A 4 x 2 x 4 mm box dragged flat 40 mm on shipped copper: a flat-bottomed groove as wide
    as the box, depth V / (x s), plus its own print x z d at the ends."""
    from dentdemo.model.shapes import Box

    x, z, load, distance = 0.004, 0.004, 2000.0, 0.04
    copper, plate, _, height = _scratch(gl, Box((x, 0.002, z)), "copper", load, distance, 512)
    volume = 3.2e-2 * load * distance / 4.9e8
    assert copper.wear_coefficient * load * distance / copper.hardness == pytest.approx(volume)
    depth = volume / (x * distance)
    texel = plate.side / 512
    assert -height.sum() * texel * texel == pytest.approx(volume + x * z * depth, rel=0.05)
    along, off = _texel_coordinates(height, plate.side, 0.0)
    inside = (np.abs(along) < distance / 2) & (np.abs(off) < x / 2 - texel)
    assert -height[inside] == pytest.approx(depth, rel=1e-3)


@pytest.mark.slow
def test_the_scratch_command_rolls_without_wear_and_drags_with(tmp_path):
    """`dentdemo scratch`: rolling without slip wears nothing (volume 0, no texel lowered);
    dragged, the summary's measured / predicted is within 5 %."""
    base = ["scratch", "--tool-size", "0.01", "--load", "5000", "--distance", "0.05"]
    base += ["--target-material", "steel", "--map-size", "512"]
    result = dentdemo(*base, "--roll", "--out", tmp_path / "roll")
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "roll" / "summary.json").read_text())
    assert summary["measured_volume_m3"] == 0.0 and summary["grooved_texels"] == 0
    assert '"measured_volume_m3": 0.0' in (tmp_path / "roll" / "summary.json").read_text()
    assert (np.load(tmp_path / "roll" / "target_height.npy") == 0).all()
    result = dentdemo(*base, "--out", tmp_path / "drag", "--render", tmp_path / "drag.png")
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "drag" / "summary.json").read_text())
    assert 0.95 <= summary["ratio"] <= 1.05
    assert summary["archard_volume_m3"] == pytest.approx(7e-3 * 5000 * 0.05 / 1.18e9)
    assert (tmp_path / "drag.png").stat().st_size > 0


@pytest.mark.slow
def test_the_scratch_command_scratches_a_cube_too(tmp_path):
    """On a cube's top face (one of its atlas's six cells): the same volume, within 5 %."""
    base = ["scratch", "--tool-size", "0.01", "--load", "5000", "--distance", "0.05"]
    base += ["--target-material", "steel", "--target", "box", "--heading", "20"]
    result = dentdemo(*base, "--out", tmp_path / "cube")
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "cube" / "summary.json").read_text())
    assert summary["target"]["kind"] == "box"
    assert 0.95 <= summary["ratio"] <= 1.05
    assert summary["archard_volume_m3"] == pytest.approx(7e-3 * 5000 * 0.05 / 1.18e9)


@pytest.mark.parametrize(
    "args,fragment",
    [
        (["--load", "-1", "--distance", "0.1"], "--load"),
        (["--load", "1", "--distance", "0"], "--distance"),
        (["--load", "1", "--distance", "0.1", "--roll", "--slip", "0.5"], "--roll"),
        (["--load", "1", "--distance", "0.1", "--target-material", "unobtainium"], "unobtainium"),
        (["--load", "1", "--distance", "0.1", "--tool-size", "0.01", "0.02"], "--tool-size"),
        (["--load", "1e9", "--distance", "50", "--target-material", "lead"], "max_dent_depth"),
    ],
)
@pytest.mark.slow
def test_the_scratch_command_refuses_bad_input(tmp_path, args, fragment):
    result = dentdemo("scratch", *args, "--out", tmp_path / "out")
    assert result.returncode != 0
    assert fragment in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_every_shipped_preset_sets_its_wear_coefficient_and_hardness():
    """Sourced K and H on every shipped preset (HV/HB x 9.80665e6 Pa: steel 120 HB, aluminium
    107 HV, by hand), each within its key's range, and `dentdemo materials --json` lists them."""
    from dentdemo.model.materials import load_materials

    lib = load_materials()
    for name, material in lib.materials.items():
        assert 0.0 < material.wear_coefficient < 0.1, name
        assert material.hardness_explicit and 1e4 < material.hardness < 1e11, name
    assert lib.get("steel").hardness == pytest.approx(120 * 9.80665e6, rel=0.01)
    assert lib.get("aluminium").hardness == pytest.approx(107 * 9.80665e6, rel=0.01)
    listed = json.loads(dentdemo("materials", "--json").stdout)["materials"]
    assert {m["name"]: m["wear_coefficient"] for m in listed}["steel"] == 7e-3


def test_wear_keys_are_validated_and_hardness_defaults_to_three_yields(tmp_toml):
    """An absent hardness_Pa is Tabor's 3 x yield stress (250 MPa -> 750 MPa); an absent
    wear_coefficient wears nothing; out of range, each is refused naming the key."""
    from dentdemo.errors import ConfigError
    from dentdemo.model.materials import load_materials, material_table, parse_material
    from scene_text import steel_like

    lib = load_materials([tmp_toml(steel_like("plain", 0.01))])
    plain = lib.get("plain")
    assert plain.hardness == pytest.approx(3 * 250e6) and not plain.hardness_explicit
    assert plain.wear_coefficient == 0.0
    again = parse_material("t", "plain", material_table(plain), lib.calibration)
    assert again == plain
    for extra, key in (
        ("wear_coefficient = -1e-3\n", "wear_coefficient"),
        ("wear_coefficient = 1.5\n", "wear_coefficient"),
        ("hardness_Pa = 0\n", "hardness_Pa"),
        ('hardness_Pa = "hard"\n', "hardness_Pa"),
    ):
        path = tmp_toml(steel_like("worn", 0.01, extra))
        with pytest.raises(ConfigError, match=f"key '{key}'"):
            load_materials([path])
