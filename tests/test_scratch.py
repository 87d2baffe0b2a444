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


def _circle_depth(r, area):
    """The depth whose circle groove (the midpoint rule, `_circle_groove_area`) is `area`."""
    lo, hi = 0.0, r
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if _circle_groove_area(r, mid, 20001) < area else (lo, mid)
    return (lo + hi) / 2


@pytest.mark.parametrize(
    "kind,heading",
    [("capsule", 30.0), ("cylinder", 0.0), ("cylinder", -50.0), ("plate", 30.0)],
)
def test_a_dragged_capsule_cylinder_or_plate_cuts_its_profile(gl, kind, heading):
    """Each tool lying along a 40 mm path on shipped steel at 5 kN (a plate face down): the
    groove holds K F s / H (the preset's, by hand) plus the tool's print at the ends within 5 %
    (a capsule: its circle's segment over its length and a sphere's cap; a cylinder: the
    segment over its length; a plate: side^2 d), and across the path's straight part its
    profile is the tool's: the circle of its radius at the depth whose integrated segment
    times the path is Archard's volume, or flat, side wide, within 3 % of the depth."""
    from dentdemo.model.shapes import Capsule, Cylinder, Plate

    r, length, side, load, distance = 0.01, 0.012, 0.006, 5000.0, 0.04
    tool = {"capsule": Capsule(r, length), "cylinder": Cylinder(r, length), "plate": Plate(side)}
    steel, plate, _, height = _scratch(gl, tool[kind], "steel", load, distance, 1024, heading)
    volume = 7e-3 * load * distance / 1.18e9
    if kind == "plate":
        depth = volume / (side * distance)
        ends = side * side * depth
    else:
        depth = _circle_depth(r, volume / distance)
        ends = volume / distance * length
        ends += math.pi * depth**2 * (3 * r - depth) / 3 if kind == "capsule" else 0.0
    texel = plate.side / 1024
    assert -height.sum() * texel * texel == pytest.approx(volume + ends, rel=0.05)
    along, off = _texel_coordinates(height, plate.side, heading)
    reach = side / 2 if kind == "plate" else math.sqrt(2 * r * depth)
    straight = (np.abs(along) < distance / 2) & (np.abs(off) < reach + 2 * texel)
    if kind == "plate":
        expected = np.where(np.abs(off) < side / 2, depth, 0.0)
        straight &= np.abs(np.abs(off) - side / 2) > texel  # the walls' texels either way
    else:
        expected = np.maximum(depth - (r - np.sqrt(np.maximum(r * r - off**2, 0.0))), 0.0)
    error = np.abs(-height[straight] - expected[straight])
    assert error.max() < 0.03 * depth, error.max() / depth


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


@pytest.mark.slow
def test_the_scratch_command_scratches_a_sphere_along_a_great_circle(tmp_path):
    """On a 50 mm sphere, 20 mm of a great circle 30 degrees off +x: the volume, -height times
    each texel's own area, is Archard's plus the two prints within 5 % (the cross-section the
    lens a ball cuts from a ball: with a flat groove's depth it would fall 9 % short here)."""
    base = ["scratch", "--tool-size", "0.01", "--load", "5000", "--distance", "0.02"]
    base += ["--target-material", "steel", "--target", "sphere", "--target-radius", "0.05"]
    result = dentdemo(*base, "--heading", "30", "--map-size", "1024", "--out", tmp_path / "s")
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert summary["target"] == {"kind": "sphere", "radius": 0.05}
    assert summary["archard_volume_m3"] == pytest.approx(7e-3 * 5000 * 0.02 / 1.18e9)
    assert 0.95 <= summary["ratio"] <= 1.05
    assert summary["segments"] > 1


def _strip_area_by_integration(big, width, depth, n=200_001):
    """The ball's circle (radius `big`) above the chord `depth` below its top, over |x| <=
    width / 2, by the midpoint rule across x (independent of `wear.strip_area`)."""
    half = min(width / 2, big)
    x = ((np.arange(n) + 0.5) / n * 2 - 1) * half
    return float(np.maximum(np.sqrt(big * big - x * x) - (big - depth), 0.0).sum() * 2 * half / n)


def _print_by_integration(big, width, length, depth, n=1500):
    """The ball's cap above the plane `depth` below its top, under a width x length face centred
    on it, by the midpoint rule over the face."""
    x = ((np.arange(n) + 0.5) / n * 2 - 1) * width / 2
    z = ((np.arange(n) + 0.5) / n * 2 - 1) * length / 2
    cut = np.sqrt(np.maximum(big * big - x[None, :] ** 2 - z[:, None] ** 2, 0.0)) - (big - depth)
    return float(np.maximum(cut, 0.0).sum() * width * length / n / n)


@pytest.mark.parametrize("width", [0.004, 0.0015])
@pytest.mark.slow
def test_the_scratch_command_drags_a_box_along_a_spheres_great_circle(tmp_path, width):
    """A box face down (4 mm, then 1.5 mm across, 2 mm along) dragged 20 mm along a great circle
    of a 50 mm sphere, 30 degrees off +x, on shipped steel at 5 kN: the groove's cross-section
    is the ball's circle above the face's chord, clipped to the face's width (the 4 mm face is
    wider than the chord, the 1.5 mm one narrower); its depth the test's own bisection of that
    integrated area against Archard's V / s; the volume, -height times each texel's area, is V
    plus the face's print on the ball (integrated) within 5 %."""
    base = ["scratch", "--tool", "box", "--tool-size", str(width), "0.002", "0.002"]
    base += ["--load", "5000", "--distance", "0.02", "--target-material", "steel"]
    base += ["--target", "sphere", "--target-radius", "0.05", "--heading", "30"]
    result = dentdemo(*base, "--map-size", "1024", "--out", tmp_path / "s")
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "s" / "summary.json").read_text())
    big, volume = 0.05, 7e-3 * 5000 * 0.02 / 1.18e9
    lo, hi = 0.0, 1e-3
    for _ in range(60):
        mid = (lo + hi) / 2
        small = _strip_area_by_integration(big, width, mid, 20001) * 0.02 < volume
        lo, hi = (mid, hi) if small else (lo, mid)
    depth = (lo + hi) / 2
    chord = math.sqrt(2 * big * depth - depth**2)
    assert (width / 2 > chord) == (width == 0.004)  # the two cases: wider, narrower
    assert summary["depth_m"] == pytest.approx(depth, rel=1e-3)
    expected = volume + _print_by_integration(big, width, 0.002, depth)
    assert summary["measured_volume_m3"] == pytest.approx(expected, rel=0.05)
    assert summary["segments"] > 1


@pytest.mark.parametrize(
    "args,fragment",
    [
        (["--load", "-1", "--distance", "0.1"], "--load"),
        (["--load", "1", "--distance", "0"], "--distance"),
        (["--load", "1", "--distance", "0.1", "--roll", "--slip", "0.5"], "--roll"),
        (["--load", "1", "--distance", "0.1", "--target-material", "unobtainium"], "unobtainium"),
        (["--load", "1", "--distance", "0.1", "--tool-size", "0.01", "0.02"], "--tool-size"),
        (["--load", "1e9", "--distance", "50", "--target-material", "lead"], "max_dent_depth"),
        (["--load", "1", "--distance", "0.1", "--target-radius", "0.1"], "--target-radius"),
        (["--load", "1", "--distance", "0.1", "--tool", "capsule", "--target", "sphere"], "--tool"),
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
    # The painted preset's coat wears by its own sourced K and H (Perspex: 20 kgf/mm^2).
    painted = {m["name"]: m for m in listed}["painted_steel"]
    assert painted["coat_wear_coefficient"] == 7e-6
    assert painted["coat_hardness_Pa"] == pytest.approx(20 * 9.80665e6, rel=1e-3)


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
    # A coat without a wear law of its own wears as the material: ratio 1.
    coated = load_materials([tmp_toml(steel_like("c", 0.01, "coat_thickness_m = 1e-4\n"))])
    assert (
        coated.get("c").coat_hardness == plain.hardness and coated.get("c").coat_wear_ratio() == 1
    )
    for extra, key in (
        ("wear_coefficient = -1e-3\n", "wear_coefficient"),
        ("wear_coefficient = 1.5\n", "wear_coefficient"),
        ("hardness_Pa = 0\n", "hardness_Pa"),
        ('hardness_Pa = "hard"\n', "hardness_Pa"),
        ("coat_wear_coefficient = 1.5\n", "coat_wear_coefficient"),
        ("coat_hardness_Pa = 0\n", "coat_hardness_Pa"),
    ):
        path = tmp_toml(steel_like("worn", 0.01, extra))
        with pytest.raises(ConfigError, match=f"key '{key}'"):
            load_materials([path])


def _lens_area_by_integration(big, r, depth, n=400_001):
    """The overlap of a ball's circle (radius `big`, centre 0) and a tool's (radius r, centre
    big + r - depth up the y axis), by the midpoint rule across x: at x the overlap runs from the
    tool's lower arc to the ball's upper one."""
    c = big + r - depth
    x = (np.arange(n) + 0.5) / n * 2 * r - r
    top = np.sqrt(np.maximum(big * big - x * x, 0.0))
    bottom = c - np.sqrt(np.maximum(r * r - x * x, 0.0))
    return float(np.maximum(top - bottom, 0.0).sum() * 2 * r / n)


@pytest.mark.parametrize("big,depth", [(0.05, 3e-5), (0.2, 4e-7), (0.02, 0.004)])
def test_lens_area_and_print_match_their_integrals(big, depth):
    """The groove's cross-section on a ball and the ball-into-ball print, against the midpoint
    rule (the print: discs across the line of centres, each the smaller of the two balls')."""
    r = 0.01
    assert wear.lens_area(big, r, depth) == pytest.approx(
        _lens_area_by_integration(big, r, depth), rel=1e-5
    )
    area = wear.lens_area(big, r, depth)
    assert wear.lens_groove_depth(big, r, area) == pytest.approx(depth, rel=1e-6)
    # Narrower than a flat target's segment: the ball falls away across the path.
    assert area < wear.segment_area(r, depth)
    c, n = big + r - depth, 400_000
    y = big - depth + (np.arange(n) + 0.5) / n * depth  # along the line of centres
    discs = np.pi * np.minimum(big * big - y * y, r * r - (c - y) ** 2)
    expected = float(np.maximum(discs, 0.0).sum() * depth / n)
    assert wear.ball_lens_volume(big, r, depth) == pytest.approx(expected, rel=1e-4)


def test_sphere_texel_areas_follow_the_mesh_and_cover_the_sphere():
    """Each texel's area on a built-in sphere: all of them sum to 4 pi R^2, and at each triangle
    of the sphere's mesh the area per unit of uv is the cell's world area over its uv area (at
    48 cells a face, flat facets within 0.2 % of the sphere's; the texel at the cell's centre
    within a tenth of a cell of it)."""
    from dentdemo.mesh.primitives import sphere, sphere_texel_areas

    radius, size = 0.05, 1536
    areas = sphere_texel_areas(radius, size, size)
    assert areas.sum() == pytest.approx(4 * math.pi * radius**2, rel=1e-4)
    mesh = sphere(radius, subdivisions=48)
    tri = mesh.indices.astype(np.int64)
    p, uv = mesh.positions.astype(np.float64)[tri], mesh.uvs.astype(np.float64)[tri]
    world = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    flat = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    # A cell's two triangles (each face: the cells' lower halves, then their upper halves).
    n = 48
    world, flat = (x.reshape(6, 2, n * n).sum(axis=1).ravel() for x in (world, flat))
    centre = uv.reshape(6, 2, n * n, 3, 2).mean(axis=(1, 3)).reshape(-1, 2)
    col = np.floor(centre[:, 0] * size).astype(int)
    row = np.floor(centre[:, 1] * size).astype(int)
    per_uv = areas[row, col] * size * size
    assert per_uv == pytest.approx(world / flat, rel=0.005)


def _atlas_directions(size):
    """Each texel centre's unit direction on a built-in sphere (rows x cols, row 0 at v = 0),
    and its chart (-1 in a gutter): the chart's 3 x 2 cell inside a gutter of 1/128, the
    equal-angle warp n + tan(s pi/4) a + tan(t pi/4) b (the atlas's specification)."""
    from dentdemo.mesh.cube import CUBE_FACES
    from dentdemo.mesh.primitives import GUTTER

    u = (np.arange(size) + 0.5) / size
    uu, vv = np.meshgrid(u, u)
    direction = np.zeros((size, size, 3))
    chart = np.full((size, size), -1)
    for face, (n, a, b) in enumerate(CUBE_FACES):
        u0, v0 = face % 3 / 3 + GUTTER, face // 3 / 2 + GUTTER
        s = (uu - u0) / (1 / 3 - 2 * GUTTER) * 2 - 1
        t = (vv - v0) / (1 / 2 - 2 * GUTTER) * 2 - 1
        inside = (np.abs(s) <= 1) & (np.abs(t) <= 1)
        d = (
            np.asarray(n)[None, None]
            + np.tan(s * math.pi / 4)[..., None] * np.asarray(a)
            + np.tan(t * math.pi / 4)[..., None] * np.asarray(b)
        )
        direction[inside] = d[inside]
        chart[inside] = face
    norm = np.linalg.norm(direction, axis=2, keepdims=True)
    return direction / np.maximum(norm, 1e-30), chart


@pytest.mark.parametrize("heading", [0.0, 30.0])
@pytest.mark.slow
def test_a_scratch_across_a_spheres_chart_seam_has_no_gap(gl, heading):
    """A 10 mm ball dragged 20 mm on shipped steel along a great circle of a 50 mm sphere, its
    middle where the circle leaves the top chart (+y) for the +x one (square across the seam,
    and 30 degrees oblique). Oracle: the ball's centre runs on the circle of radius R + r - d
    over the path's arc (d from the test's own bisection of the integrated lens), and a surface
    point p sinks to where its ray leaves the ball nearest it. Every texel the oracle puts more
    than d/4 deep is dented on both charts; every texel's depth matches within 12 % of d (the
    chords' sag makes a groove d - 6.7 % .. d + 3.3 % deep along the path, the carve's sampling
    of the rim the rest), in the groove, at the seam and beyond the rim alike."""
    from dentdemo.app.scratch import Drag, carve_groove, make_scratch
    from dentdemo.model.materials import load_materials
    from dentdemo.model.shapes import Sphere

    big, r, load, distance, size = 0.05, 0.01, 5000.0, 0.02, 1024
    steel = load_materials().get("steel")
    h = math.radians(heading)
    way, top = np.array([math.cos(h), 0.0, math.sin(h)]), np.array([0.0, 1.0, 0.0])
    seam = math.atan(1.0 / math.cos(h))  # where x = y on the circle through the top along way
    setup = make_scratch(
        gl, Sphere(big), Sphere(r), steel, Drag(load, distance, 1.0), size, h, arc_middle=seam
    )
    try:
        carve_groove(gl, setup)
        height = gl.read(setup.target.maps.height)[:, :, 0].astype(np.float64)
    finally:
        setup.release()
    volume = 7e-3 * load * distance / 1.18e9
    lo, hi = 0.0, r
    for _ in range(60):
        mid = (lo + hi) / 2
        small = _lens_area_by_integration(big, r, mid, 20001) * distance < volume
        lo, hi = (mid, hi) if small else (lo, mid)
    depth = (lo + hi) / 2
    p, chart = _atlas_directions(size)
    angle = np.arctan2(p @ way, p @ top)
    half_arc = distance / big / 2
    # The ball's centre nearest p's ray: in the circle's plane at p's own angle, clamped to the
    # path's arc.
    centre = (big + r - depth) * (
        np.cos(np.clip(angle, seam - half_arc, seam + half_arc))[..., None] * top
        + np.sin(np.clip(angle, seam - half_arc, seam + half_arc))[..., None] * way
    )
    along = (p * centre).sum(axis=2)
    reach = r * r - (centre * centre).sum(axis=2) + along**2
    exit_ = along - np.sqrt(np.maximum(reach, 0.0))
    hit = (reach > 0) & (along > 0) & (exit_ < big) & (chart >= 0)  # p's own side, not -p's
    expected = np.where(hit, big - exit_, 0.0)
    grooved = expected > depth / 4
    for face in (2, 0):  # the top chart and the +x one, each holds half the groove
        assert (grooved & (chart == face)).sum() > 100, face
        assert (height[grooved & (chart == face)] < 0).all(), face
    # Everywhere on the charts, the groove and beyond its rim (the oracle's 0) alike.
    error = np.abs(-height - expected)[chart >= 0]
    assert error.max() < 0.12 * depth, error.max() / depth
    # Continuity: within 2 mm of the seam along the path, either side's depths match the oracle.
    near = (np.abs(angle - seam) < 0.002 / big) & (expected > 0)
    for face in (2, 0):
        side = near & (chart == face)
        assert side.sum() > 10 and np.abs(-height - expected)[side].max() < 0.12 * depth, face


def _texel_points(mesh, size):
    """Each texel centre's point on `mesh` and its face's outward normal (rows x cols x 3; NaN
    where no triangle covers it), by rasterising the atlas's triangles on the CPU: the texel
    centres inside each triangle's uv, their barycentric weights times its corners."""
    points = np.full((size, size, 3), np.nan)
    normals = np.full((size, size, 3), np.nan)
    p = mesh.positions.astype(np.float64)[mesh.indices]
    t = mesh.uvs.astype(np.float64)[mesh.indices] * size - 0.5  # texel-centre units
    for corners, uv in zip(p, t, strict=True):
        lo = np.floor(uv.min(axis=0)).astype(int)
        hi = np.ceil(uv.max(axis=0)).astype(int)
        cols, rows = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1))
        e1, e2 = uv[1] - uv[0], uv[2] - uv[0]
        det = e1[0] * e2[1] - e1[1] * e2[0]
        dx, dy = cols - uv[0, 0], rows - uv[0, 1]
        b1 = (dx * e2[1] - dy * e2[0]) / det
        b2 = (e1[0] * dy - e1[1] * dx) / det
        inside = (b1 >= -1e-9) & (b2 >= -1e-9) & (b1 + b2 <= 1 + 1e-9)
        inside &= (rows >= 0) & (rows < size) & (cols >= 0) & (cols < size)
        b1, b2 = b1[inside], b2[inside]
        at = (
            corners[0]
            + b1[:, None] * (corners[1] - corners[0])
            + b2[:, None] * (corners[2] - corners[0])
        )
        n = np.cross(corners[1] - corners[0], corners[2] - corners[0])
        points[rows[inside], cols[inside]] = at
        normals[rows[inside], cols[inside]] = n / np.linalg.norm(n)
    return points, normals


@pytest.mark.parametrize("heading", [0.0, 30.0])
@pytest.mark.slow
def test_a_scratch_across_a_boxs_edge_has_no_gap(gl, heading):
    """A 10 mm ball dragged 10 mm on the top of a 30 mm steel cube to the middle of its +x edge,
    pivoting about the edge and 10 mm on down the +x face (square to the edge, and 30 degrees
    oblique). Oracle: the ball's centre runs r - d from the surface (over the faces, and round
    the edge on a quarter circle r - d from it; d from the test's own bisection of the integrated
    circle), and a texel sinks along its face's inward normal to the lowest point its line meets
    the balls along that path. Every texel the oracle puts more than d/4 deep is dented, on the
    top face's chart and on the +x face's, near the edge too; every texel's depth matches within
    15 % of d, in the groove and beyond its rim alike."""
    from dentdemo.app.scratch import Drag, carve_groove, make_scratch
    from dentdemo.mesh.shapes import Tessellation, shape_mesh
    from dentdemo.model.materials import load_materials
    from dentdemo.model.shapes import Box, Sphere

    side, r, load, distance, size = 0.03, 0.01, 5000.0, 0.02, 1024
    steel = load_materials().get("steel")
    h = math.radians(heading)
    cube = Box((side, side, side))
    setup = make_scratch(
        gl, cube, Sphere(r), steel, Drag(load, distance, 1.0), size, h, over_edge=True
    )
    try:
        carve_groove(gl, setup)
        height = gl.read(setup.target.maps.height)[:, :, 0].astype(np.float64)
    finally:
        setup.release()
    depth = _circle_depth(r, 7e-3 * load * distance / 1.18e9 / distance)
    e = side / 2
    run = distance / 2
    u = np.linspace(0.0, run, 201)[:, None]
    phi = np.linspace(0.0, math.pi / 2, 201)[:, None]
    k = r - depth
    path = np.vstack(
        [
            np.hstack([e - (run - u) * math.cos(h), e + k + 0 * u, -(run - u) * math.sin(h)]),
            np.hstack([e + k * np.sin(phi), e + k * np.cos(phi), 0 * phi]),
            np.hstack([e + k + 0 * u, e - u * math.cos(h), u * math.sin(h)]),
        ]
    )
    points, normals = _texel_points(shape_mesh(cube, Tessellation.press(2)), size)
    expected = np.zeros(height.shape)
    for axis, face in ((1, "top"), (0, "side")):
        on = normals[..., axis] > 0.5  # the +y face's texels, then the +x face's
        # Those within r of the path's box (the rest the balls never meet).
        on &= ((points > path.min(axis=0) - r) & (points < path.max(axis=0) + r)).all(axis=2)
        p = points[on]
        others = [i for i in range(3) if i != axis]
        rho2 = sum((p[:, None, i] - path[None, :, i]) ** 2 for i in others)
        reach = np.sqrt(np.maximum(r * r - rho2, 0.0))
        met = rho2 < r * r
        lowest = np.where(met, path[None, :, axis] - reach, np.inf).min(axis=1)
        highest = np.where(met, path[None, :, axis] + reach, -np.inf).max(axis=1)
        inside = (highest >= e) & (lowest < e)
        expected[on] = np.where(inside, e - lowest, 0.0)
        grooved = on & (expected > depth / 4)
        assert grooved.sum() > 100, face
        assert (height[grooved] < 0).all(), (face, (height[grooved] >= 0).sum())
        near = grooved & (np.abs(points[..., others[0]] - e) < r / 4)  # by the edge
        assert near.sum() > 10 and (height[near] < 0).all(), face
    charts = ~np.isnan(normals[..., 0])
    error = np.abs(-height - expected)[charts]
    assert error.max() < 0.15 * depth, error.max() / depth


def _coated_depth(r, coat, ratio, area):
    """The depth d at which a groove through a coat holds the work that would cut `area` out of
    the bare metal: ratio (A(d) - A(d - t)) + A(d - t) = area, A the integrated circle, by the
    test's own bisection (a coat `ratio` times as hard to wear as the metal)."""
    lo, hi = 0.0, r
    for _ in range(60):
        mid = (lo + hi) / 2
        below = _circle_groove_area(r, max(mid - coat, 0.0), 20001)
        held = ratio * (_circle_groove_area(r, mid, 20001) - below) + below
        lo, hi = (mid, hi) if held < area else (lo, mid)
    return (lo + hi) / 2


@pytest.mark.parametrize("share", [0.95, 1.05, 1.3])
@pytest.mark.slow
def test_paint_wears_by_its_own_law_until_the_metal(gl, share):
    """A 10 mm ball dragged 40 mm over the shipped painted steel (a 0.1 mm acrylic coat: K
    7e-6, H 20 kgf/mm^2; the steel K 7e-3, H 120 HB, all by hand). Within the coat Archard's law
    takes the coat's K and H: the groove reaches the metal at the load F* = A(t) H_c / K_c, A(t)
    the circle's segment at the coat's thickness (integrated). At 0.95 F* its depth is the coat's
    own Archard depth and no texel is bare; at 1.05 F* bare metal shows; at 1.3 F* the work left
    after the coat's band cuts the steel at the steel's rate: the depth is the test's own
    two-layer solution, within 3 %, and the metal's volume (below the coat) and the coat's are
    each that solution's within 5 %."""
    from dentdemo.model.shapes import Sphere

    r, distance, coat = 0.01, 0.04, 1e-4
    coat_k, coat_h, steel_k, steel_h = 7e-6, 20 * 9.80665e6, 7e-3, 120 * 9.80665e6
    threshold = _circle_groove_area(r, coat) * coat_h / coat_k
    load = share * threshold
    painted, plate, setup, height = _scratch(gl, Sphere(r), "painted_steel", load, distance, 1024)
    assert painted.coat_wear_coefficient == coat_k and painted.appearance.coat_thickness == coat
    assert painted.coat_hardness == pytest.approx(coat_h, rel=1e-3)
    assert painted.hardness == pytest.approx(steel_h, rel=0.01)
    along, off = _texel_coordinates(height, plate.side, 0.0)
    texel = plate.side / 1024
    middle = np.abs(along) < distance / 4
    deepest = -height[middle].min()
    if share < 1:
        depth = _circle_depth(r, coat_k * load / coat_h)  # the coat's own law alone
        assert depth < coat and deepest == pytest.approx(depth, rel=0.03)
        assert not (height < -coat).any()
        return
    assert (height < -coat).sum() > 20
    if share < 1.2:
        return
    ratio = (steel_k / steel_h) / (coat_k / coat_h)
    depth = _coated_depth(r, coat, ratio, steel_k * load / steel_h)
    assert deepest == pytest.approx(depth, rel=0.03)
    metal = _circle_groove_area(r, depth - coat) * distance
    metal += math.pi * (depth - coat) ** 2 * (3 * r - depth + coat) / 3  # the ends' cap
    below = np.maximum(-height - coat, 0.0).sum() * texel * texel
    assert below == pytest.approx(metal, rel=0.05)
    whole = _circle_groove_area(r, depth) * distance + math.pi * depth**2 * (3 * r - depth) / 3
    paint = -height.sum() * texel * texel - below
    assert paint == pytest.approx(whole - metal, rel=0.05)
