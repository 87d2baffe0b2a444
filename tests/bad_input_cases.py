"""The table of bad (and borderline) inputs for tests/test_bad_input.py, over six areas: scene
files, mesh files, bump-map PNGs, materials files, command-line flags and the environment.

A case rejects (`reject`: fragments the one stderr line must hold, such as the file, key or flag
and the value) or accepts (`accept`: a check of its effect on what the command printed or wrote).
Paths in argv may use {d}, the case's own folder (also the working directory); outputs go under
{d}/out, which must be empty or absent after a rejection.
"""

from __future__ import annotations

import io
import json
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image

from mesh_helpers import glb, gltf, grid

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Case:
    id: str
    area: str
    argv: list[str]
    files: dict[str, str | bytes] = field(default_factory=dict)
    env: dict[str, str | None] = field(default_factory=dict)
    reject: tuple[str, ...] | None = None
    #: For accepted cases: (stdout, stderr, case folder) -> raises AssertionError when wrong.
    accept: Callable[[str, str, Path], None] | None = None


def _png(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(array).save(buffer, format="PNG")
    return buffer.getvalue()


GROUND = '[[body]]\nid = "ground"\nshape = "plane"\nmaterial = "oak"\n'
PLATE = (
    '[[body]]\nid = "plate"\nshape = "plate"\nside = 0.3\nmaterial = "aluminium"\n'
    "position = [0.0, 0.02, 0.0]\nstatic = true\ntexels_per_metre = 64\n"
)
BALL = (
    '[[body]]\nid = "ball"\nshape = "sphere"\nradius = 0.05\nmaterial = "steel"\n'
    "position = [0.0, 0.3, 0.0]\n"
)
SCENE = '[scene]\nname = "t"\n\n' + GROUND + "\n" + PLATE + "\n" + BALL
SIMULATE = ["simulate", "--scene", "s.toml", "--steps", "3"]
RENDER = ["render", "--scene", "s.toml", "--frames", "1", "--size", "32x32", "--out", "out/x.png"]
INDENT = ["indent", "--depth", "0.002", "--map-size", "64", "--out", "out/press"]

OBJ_TRIANGLE = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
#: A closed tetrahedron (10 cm edges), outward faces, no texture coordinates.
OBJ_TETRA = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
#: A 1 m square, facing up, 0.3 m above its origin: open, though its cone from the origin
#: holds 0.1 m^3.
OBJ_SHEET = "v 0 0.3 0\nv 1 0.3 0\nv 1 0.3 -1\nv 0 0.3 -1\nf 1 2 3\nf 1 3 4\n"
MATERIAL_OK = (
    "[materials.tin]\nyoungs_modulus_Pa = 50e9\nyield_stress_Pa = 10e6\n"
    "plastic_modulus_Pa = 0.5e9\ndensity_kg_m3 = 7300\nrestitution = 0.3\nfriction = 0.5\n"
    "max_dent_depth_m = 0.02\n"
)


def _scene(old: str, new: str, base: str = SCENE) -> str:
    assert old in base, old
    return base.replace(old, new, 1)


def _ball(extra: str) -> str:
    """The scene with `extra` lines added to the ball's table."""
    return SCENE + extra + "\n"


def _mesh_scene(mesh: str, extra: str = "") -> str:
    return (
        SCENE
        + f'\n[[body]]\nid = "thing"\nshape = "mesh"\nmesh = "{mesh}"\nmaterial = "copper"\n'
        + "position = [0.5, 0.3, 0.0]\n"
        + extra
    )


def _bump_scene(png: str, extra: str = "") -> str:
    return _scene("texels_per_metre = 64\n", f'texels_per_metre = 64\nbump_map = "{png}"\n{extra}')


def _stdout_has(*needles: str) -> Callable[[str, str, Path], None]:
    def check(out: str, err: str, folder: Path) -> None:
        for needle in needles:
            assert needle in out, (needle, out)

    return check


def _plate_bump_peak(expected_m: float) -> Callable[[str, str, Path], None]:
    """The plate's exported height map peaks at `expected_m` (the bump's white)."""

    def check(out: str, err: str, folder: Path) -> None:
        height = np.load(folder / "out" / "maps" / "plate_height.npy")
        assert abs(float(height.max()) - expected_m) < 1e-6, float(height.max())

    return check


def _materials_json(name: str, key: str, value: float) -> Callable[[str, str, Path], None]:
    def check(out: str, err: str, folder: Path) -> None:
        entries = {m["name"]: m for m in json.loads(out)["materials"]}
        assert entries[name][key] == value, entries[name]

    return check


def _one_warning(fragment: str) -> Callable[[str, str, Path], None]:
    def check(out: str, err: str, folder: Path) -> None:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("dentdemo:") and fragment in lines[0], err

    return check


def _clamped_press(bound: float) -> Callable[[str, str, Path], None]:
    """One warning line that the depth was clamped to `bound` m, and a dent that deep."""

    def check(out: str, err: str, folder: Path) -> None:
        _one_warning(f"clamped to {bound:g} m")(out, err, folder)
        summary = json.loads((folder / "out" / "press" / "summary.json").read_text())
        assert summary["depth_m"] == bound, summary
        assert abs(summary["max_depth_m"] - bound) < 0.02 * bound, summary

    return check


def _simulated_seconds(
    seconds: float, shot: str, size: tuple[int, int]
) -> Callable[[str, str, Path], None]:
    """The demo ran `seconds` of the default scene (frames of its dt, read from the file) and
    saved a `size` screenshot."""
    scene = tomllib.loads((ROOT / "assets" / "scenes" / "ball_drop.toml").read_text())
    frames = round(seconds / scene["physics"]["dt"])

    def check(out: str, err: str, folder: Path) -> None:
        assert f"({frames} frames)" in err, (frames, err)
        with Image.open(folder / shot) as image:
            assert image.size == size

    return check


def _silent(out: str, err: str, folder: Path) -> None:
    assert err == "", err


def _wrote(path: str) -> Callable[[str, str, Path], None]:
    def check(out: str, err: str, folder: Path) -> None:
        assert (folder / path).is_file() and (folder / path).stat().st_size > 0, path

    return check


def _state_replaced(folder_name: str) -> Callable[[str, str, Path], None]:
    """A saved state replaced the earlier one as a whole: only its files, none of the old
    folder's, and no temporary folder beside it."""

    def check(out: str, err: str, folder: Path) -> None:
        state = folder / folder_name
        names = sorted(p.name for p in state.iterdir())
        assert "state.json" in names and "old.npy" not in names, names
        assert all(n == "state.json" or n.endswith(".npy") for n in names), names
        assert json.loads((state / "state.json").read_text())["format"] == "dentdemo-state"
        assert not [p for p in folder.iterdir() if p.name.startswith(f".{folder_name}.")]

    return check


def _rendered_with(backend: str) -> Callable[[str, str, Path], None]:
    def check(out: str, err: str, folder: Path) -> None:
        assert f"GL backend:  {backend}" in out, out

    return check


def scene_cases() -> list[Case]:
    s = "s.toml"
    table: list[tuple[str, str | bytes, tuple[str, ...]]] = [
        ("not_utf8", SCENE.encode() + b"\n# caf\xe9\n", (s, "not UTF-8")),
        ("malformed", SCENE + "\n[[body]\n", (s, "malformed TOML")),
        ("unknown_table", SCENE + "\n[fog]\ndensity = 1\n", (s, "[fog]", "unknown table")),
        ("body_not_array", '[body]\nid = "x"\n', (s, "[[body]]")),
        ("missing_id", _scene('id = "ball"\n', ""), (s, "missing key 'id'")),
        ("id_slash", _scene('id = "ball"', 'id = "a/b"'), (s, "'id'", "a/b")),
        ("id_dotdot", _scene('id = "ball"', 'id = ".."'), (s, "'id'", "'..'")),
        ("id_empty", _scene('id = "ball"', 'id = ""'), (s, "'id'")),
        ("id_hidden", _scene('id = "ball"', 'id = ".ball"'), (s, ".ball")),
        ("id_number", _scene('id = "ball"', "id = 7"), (s, "'id' = 7", "string")),
        ("duplicate_id", _scene('id = "ball"', 'id = "plate"'), (s, "'plate'", "duplicate")),
        ("unknown_shape", _scene('shape = "sphere"', 'shape = "cone"'), (s, "'cone'")),
        ("radius_zero", _scene("radius = 0.05", "radius = 0"), (s, "'radius' = 0")),
        ("radius_negative", _scene("radius = 0.05", "radius = -1"), (s, "'radius' = -1")),
        ("radius_string", _scene("radius = 0.05", 'radius = "big"'), (s, "radius", "number")),
        ("radius_nan", _scene("radius = 0.05", "radius = nan"), (s, "radius", "finite")),
        ("radius_inf", _scene("radius = 0.05", "radius = inf"), (s, "radius", "finite")),
        ("radius_huge", _scene("radius = 0.05", "radius = 1e6"), (s, "radius", "100")),
        ("radius_tiny", _scene("radius = 0.05", "radius = 1e-6"), (s, "radius", "0.001")),
        ("missing_radius", _scene("radius = 0.05\n", ""), (s, "missing key 'radius'")),
        (
            "box_two_sizes",
            SCENE + '\n[[body]]\nid = "b"\nshape = "box"\nsize = [1, 2]\nmaterial = "oak"\n',
            (s, "'size'", "3 numbers"),
        ),
        (
            "box_zero_edge",
            SCENE + '\n[[body]]\nid = "b"\nshape = "box"\nsize = [1, 0, 1]\nmaterial = "oak"\n',
            (s, "'size'", "edges"),
        ),
        (
            "unknown_material",
            _scene('material = "steel"', 'material = "kryptonite"'),
            (s, "kryptonite"),
        ),
        ("unknown_key", _ball("colour = [1, 0, 0]"), (s, "'colour'", "unknown key")),
        (
            "gravity_huge",
            _scene("[scene]", "[physics]\ngravity = [0, -1e12, 0]\n[scene]"),
            (s, "gravity", "1000"),
        ),
        (
            "gravity_nan",
            _scene("[scene]", "[physics]\ngravity = [0, nan, 0]\n[scene]"),
            (s, "gravity", "finite"),
        ),
        (
            "gravity_string",
            _scene("[scene]", '[physics]\ngravity = "down"\n[scene]'),
            (s, "gravity", "list"),
        ),
        ("velocity_huge", _ball("velocity = [0, -1e9, 0]"), (s, "velocity", "speed")),
        ("spin_huge", _ball("angular_velocity = [1e5, 0, 0]"), (s, "angular_velocity")),
        (
            "position_far",
            _ball("position = [1e7, 0, 0]").replace("position = [0.0, 0.3, 0.0]\n", "", 1),
            (s, "position"),
        ),
        (
            "substeps_float",
            _scene("[scene]", "[physics]\nsubsteps = 2.5\n[scene]"),
            (s, "substeps", "integer"),
        ),
        (
            "substeps_float_whole",
            _scene("[scene]", "[physics]\nsubsteps = 2.0\n[scene]"),
            (s, "substeps", "integer"),
        ),
        (
            "substeps_zero",
            _scene("[scene]", "[physics]\nsubsteps = 0\n[scene]"),
            (s, "'substeps' = 0"),
        ),
        (
            "substeps_huge",
            _scene("[scene]", "[physics]\nsubsteps = 100000\n[scene]"),
            (s, "substeps"),
        ),
        (
            "iterations_zero",
            _scene("[scene]", "[physics]\nsolver_iterations = 0\n[scene]"),
            (s, "solver_iterations"),
        ),
        ("dt_zero", _scene("[scene]", "[physics]\ndt = 0\n[scene]"), (s, "'dt' = 0")),
        ("dt_one", _scene("[scene]", "[physics]\ndt = 1.0\n[scene]"), (s, "'dt' = 1.0")),
        (
            "impact_speed_negative",
            _scene("[scene]", "[physics]\nimpact_speed_min = -1\n[scene]"),
            (s, "impact_speed_min"),
        ),
        (
            "impact_speed_huge",
            _scene("[scene]", "[physics]\nimpact_speed_min = 1e6\n[scene]"),
            (s, "impact_speed_min"),
        ),
        ("physics_unknown", _scene("[scene]", "[physics]\nwind = 3\n[scene]"), (s, "'wind'")),
        ("fov_zero", _scene("[scene]", "[camera]\nfov_deg = 0\n[scene]"), (s, "fov_deg")),
        (
            "eye_is_target",
            _scene("[scene]", "[camera]\neye = [1, 1, 1]\ntarget = [1, 1, 1]\n[scene]"),
            (s, "eye and target"),
        ),
        ("eye_far", _scene("[scene]", "[camera]\neye = [1e9, 0, 0]\n[scene]"), (s, "eye")),
        (
            "light_zero",
            _scene("[scene]", "[light]\ndirection = [0, 0, 0]\n[scene]"),
            (s, "direction"),
        ),
        ("ambient_two", _scene("[scene]", "[light]\nambient = 2\n[scene]"), (s, "ambient")),
        (
            "plane_dynamic",
            _scene('shape = "plane"', 'shape = "plane"\nstatic = false'),
            (s, "static", "plane"),
        ),
        ("static_string", _ball('static = "yes"'), (s, "static", "true or false")),
        (
            "texels_zero",
            _scene("texels_per_metre = 64", "texels_per_metre = 0"),
            (s, "texels_per_metre"),
        ),
        (
            "texels_huge",
            _scene("texels_per_metre = 64", "texels_per_metre = 1e9"),
            (s, "texels_per_metre"),
        ),
        ("rotation_two", _ball("rotation_deg = [0, 0]"), (s, "rotation_deg")),
        ("bump_height_negative", _ball("bump_height_m = -1"), (s, "bump_height_m")),
        ("bump_missing", _ball('bump_map = "nope.png"'), (s, "bump_map", "nope.png")),
        ("mesh_missing", _mesh_scene("nope.obj"), (s, "'mesh'", "nope.obj")),
        ("scene_name_number", _scene('name = "t"', "name = 5"), (s, "'name' = 5")),
    ]
    cases = [
        Case(f"scene-{name}", "scene", SIMULATE, {"s.toml": text}, reject=fragments)
        for name, text, fragments in table
    ]
    cases += [
        Case("scene-missing_file", "scene", SIMULATE, reject=("s.toml", "no such file")),
        Case(
            "scene-is_a_folder",
            "scene",
            SIMULATE,
            {"s.toml/inside.txt": "x"},
            reject=("s.toml", "cannot read"),
        ),
        Case(
            "scene-empty_file_accepted",
            "scene",
            SIMULATE,
            {"s.toml": ""},
            accept=_stdout_has("0 impacts in 3 steps (0 bodies"),
        ),
        Case(
            "scene-substeps_integer_accepted",
            "scene",
            SIMULATE,
            {"s.toml": _scene("[scene]", "[physics]\nsubsteps = 3\n[scene]")},
            accept=_stdout_has("substeps 3"),
        ),
        Case(
            "scene-zero_gravity_accepted",
            "scene",
            ["simulate", "--scene", "s.toml", "--steps", "60"],
            {"s.toml": _scene("[scene]", "[physics]\ngravity = [0, 0, 0]\n[scene]")},
            accept=_stdout_has("0 impacts in 60 steps (3 bodies"),
        ),
    ]
    return cases


def mesh_cases() -> list[Case]:
    s = "s.toml"
    table: list[tuple[str, str, str | bytes, tuple[str, ...]]] = [
        ("binary_garbage_obj", "m.obj", bytes(range(256)) * 4, ("m.obj", "cannot load mesh")),
        ("empty_obj", "m.obj", "", ("m.obj",)),
        ("vertices_only", "m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", ("m.obj", "no triangles")),
        ("nan_vertex", "m.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", ("m.obj",)),
        ("collinear", "m.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", ("m.obj", "no area")),
        ("garbage_stl", "m.stl", bytes(range(200)), ("m.stl", "cannot load mesh")),
        ("unknown_format", "m.xyz", "1 2 3\n", ("m.xyz", "cannot load mesh")),
        ("garbage_glb", "m.glb", b"glTF" + bytes(60), ("m.glb", "cannot load mesh")),
        (
            "ply_points",
            "m.ply",
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
            "property float y\nproperty float z\nend_header\n0 0 0\n",
            ("m.ply",),
        ),
        ("text_as_obj", "m.obj", "this is not a mesh\n" * 5, ("m.obj",)),
    ]
    cases = [
        Case(f"mesh-{name}", "mesh", SIMULATE, {s: _mesh_scene(file), file: data}, reject=frag)
        for name, file, data, frag in table
    ]
    cases += [
        Case(
            "mesh-tiny_scale",
            "mesh",
            SIMULATE,
            {s: _mesh_scene("m.obj", "scale = 1e-9\n"), "m.obj": OBJ_TRIANGLE},
            reject=("m.obj", "no area", "1e-09"),
        ),
        Case(
            "mesh-huge_scale",
            "mesh",
            SIMULATE,
            {s: _mesh_scene("m.obj", "scale = 1e6\n"), "m.obj": OBJ_TRIANGLE},
            reject=(s, "scale", "1000"),
        ),
        Case(
            "mesh-is_a_folder",
            "mesh",
            SIMULATE,
            {s: _mesh_scene("m.obj"), "m.obj/x.txt": "x"},
            reject=(s, "'mesh'", "m.obj"),
        ),
        Case(
            "mesh-no_uvs_warns_once",
            "mesh",
            SIMULATE,
            {s: _mesh_scene("m.obj"), "m.obj": OBJ_TETRA},
            accept=_one_warning("re-atlasing"),
        ),
        Case(
            "mesh-open_dynamic_mesh",
            "mesh",
            SIMULATE,
            {s: _mesh_scene("m.obj"), "m.obj": OBJ_TRIANGLE},
            reject=(s, "thing", "m.obj", "no volume"),
        ),
        Case(
            "mesh-open_dynamic_sheet_off_its_origin",
            "mesh",
            SIMULATE,
            {s: _mesh_scene("m.obj"), "m.obj": OBJ_SHEET},
            reject=(s, "thing", "m.obj", "no volume", "open", "100%", "static = true"),
        ),
        Case(
            "mesh-glb_own_uvs_without_material_kept",
            "mesh",
            SIMULATE,
            {s: _mesh_scene("m.glb", "static = true\n"), "m.glb": glb(*gltf(*grid(), False))},
            accept=_silent,  # no "texture coordinates are missing; re-atlasing"
        ),
        Case(
            "mesh-open_static_mesh_accepted",
            "mesh",
            ["--quiet", *SIMULATE],
            {s: _mesh_scene("m.obj", "static = true\n"), "m.obj": OBJ_TRIANGLE},
            accept=_stdout_has("(4 bodies"),
        ),
        Case(
            "mesh-no_uvs_quiet",
            "mesh",
            ["--quiet", *SIMULATE],
            {s: _mesh_scene("m.obj"), "m.obj": OBJ_TETRA},
            accept=_silent,
        ),
        Case(
            "mesh-no_uvs_quiet_after_command",
            "mesh",
            [*SIMULATE, "--quiet"],
            {s: _mesh_scene("m.obj"), "m.obj": OBJ_TETRA},
            accept=_silent,
        ),
    ]
    return cases


def bump_cases() -> list[Case]:
    s = "s.toml"
    white16 = _png(np.full((8, 8), 65535, np.uint16))
    white8 = _png(np.full((8, 8), 255, np.uint8))
    rgba = _png(np.full((8, 8, 4), 255, np.uint8))
    good = _png(np.full((8, 8), 128, np.uint8))
    maps = [*RENDER, "--maps-dir", "out/maps"]
    table: list[tuple[str, str | bytes, tuple[str, ...]]] = [
        ("garbage", bytes(range(256)), ("b.png", "cannot read the height image")),
        ("empty", b"", ("b.png", "cannot read the height image")),
        ("text", "not a png\n", ("b.png", "cannot read the height image")),
        ("truncated", good[: len(good) // 2], ("b.png", "cannot read the height image")),
    ]
    cases = [
        Case(f"bump-{name}", "bump", RENDER, {s: _bump_scene("b.png"), "b.png": data}, reject=frag)
        for name, data, frag in table
    ]
    cases += [
        Case(
            "bump-height_too_tall",
            "bump",
            RENDER,
            {s: _bump_scene("b.png", "bump_height_m = 0.5\n"), "b.png": good},
            reject=(s, "bump_height_m", "0.5"),
        ),
        Case(
            "bump-height_nan",
            "bump",
            RENDER,
            {s: _bump_scene("b.png", "bump_height_m = nan\n"), "b.png": good},
            reject=(s, "bump_height_m", "finite"),
        ),
        Case(
            "bump-is_a_folder",
            "bump",
            RENDER,
            {s: _bump_scene("b.png"), "b.png/x.txt": "x"},
            reject=(s, "bump_map", "b.png"),
        ),
        Case(
            "bump-16bit_white_is_the_bump_height",
            "bump",
            maps,
            {s: _bump_scene("b.png", "bump_height_m = 0.002\n"), "b.png": white16},
            accept=_plate_bump_peak(0.002),
        ),
        Case(
            "bump-8bit_white_is_the_bump_height",
            "bump",
            maps,
            {s: _bump_scene("b.png", "bump_height_m = 0.002\n"), "b.png": white8},
            accept=_plate_bump_peak(0.002),
        ),
        Case(
            "bump-rgba_white_is_the_bump_height",
            "bump",
            maps,
            {s: _bump_scene("b.png", "bump_height_m = 0.003\n"), "b.png": rgba},
            accept=_plate_bump_peak(0.003),
        ),
    ]
    return cases


def materials_cases() -> list[Case]:
    m = "m.toml"
    argv = ["materials", "--materials", m, "--json"]

    def tin(old: str, new: str) -> str:
        return _scene(old, new, MATERIAL_OK)

    table: list[tuple[str, str | bytes, tuple[str, ...]]] = [
        ("not_utf8", MATERIAL_OK.encode() + b"# \xff\n", (m, "not UTF-8")),
        ("malformed", MATERIAL_OK + "[materials\n", (m, "malformed TOML")),
        ("unknown_table", MATERIAL_OK + "[metals]\nx = 1\n", (m, "metals")),
        (
            "restitution_one",
            tin("restitution = 0.3", "restitution = 1.0"),
            (m, "restitution", "1.0"),
        ),
        (
            "restitution_negative",
            tin("restitution = 0.3", "restitution = -0.1"),
            (m, "restitution", "-0.1"),
        ),
        (
            "youngs_zero",
            tin("youngs_modulus_Pa = 50e9", "youngs_modulus_Pa = 0"),
            (m, "youngs_modulus_Pa"),
        ),
        (
            "plastic_above_youngs",
            tin("plastic_modulus_Pa = 0.5e9", "plastic_modulus_Pa = 60e9"),
            (m, "plastic_modulus_Pa"),
        ),
        ("density_zero", tin("density_kg_m3 = 7300", "density_kg_m3 = 0"), (m, "density_kg_m3")),
        ("friction_eleven", tin("friction = 0.5", "friction = 11"), (m, "friction", "11")),
        (
            "depth_zero",
            tin("max_dent_depth_m = 0.02", "max_dent_depth_m = 0"),
            (m, "max_dent_depth_m"),
        ),
        (
            "depth_two",
            tin("max_dent_depth_m = 0.02", "max_dent_depth_m = 2"),
            (m, "max_dent_depth_m"),
        ),
        ("unknown_key", MATERIAL_OK + "hardness = 3\n", (m, "hardness")),
        (
            "string_value",
            tin("density_kg_m3 = 7300", 'density_kg_m3 = "heavy"'),
            (m, "density_kg_m3"),
        ),
        ("nan_value", tin("friction = 0.5", "friction = nan"), (m, "friction")),
        ("k_negative", MATERIAL_OK + "k_m_per_Ns = -1\n", (m, "k_m_per_Ns")),
        ("missing_key", tin("density_kg_m3 = 7300\n", ""), (m, "density_kg_m3")),
        ("calibration_unknown", "[calibration]\nfudge = 2\n", (m, "fudge")),
        ("calibration_negative", "[calibration]\nk_per_compliance = -1\n", (m, "k_per_compliance")),
        ("material_not_table", "[materials]\ntin = 5\n", (m, "tin")),
        # Issue 46 item 1: values that passed and then aborted ODE or overflowed numpy; each
        # refusal gives the key's range.
        (
            "density_1e200",
            tin("density_kg_m3 = 7300", "density_kg_m3 = 1e200"),
            (m, "density_kg_m3", "1e+200", "range [0.1, 100000] kg/m^3"),
        ),
        (
            "density_1e308",
            tin("density_kg_m3 = 7300", "density_kg_m3 = 1e308"),
            (m, "density_kg_m3", "1e+308", "range [0.1, 100000]"),
        ),
        (
            "density_tiny",
            tin("density_kg_m3 = 7300", "density_kg_m3 = 1e-300"),
            (m, "density_kg_m3", "range [0.1, 100000]"),
        ),
        (
            "k_1e308",
            MATERIAL_OK + "k_m_per_Ns = 1e308\n",
            (m, "k_m_per_Ns", "1e+308", "range [0, 1000]"),
        ),
        (
            "youngs_1e300",
            tin("youngs_modulus_Pa = 50e9", "youngs_modulus_Pa = 1e300"),
            (m, "youngs_modulus_Pa", "range [10000, 1e+13]"),
        ),
        (
            "plastic_tiny_derived_k",
            tin("plastic_modulus_Pa = 0.5e9", "plastic_modulus_Pa = 1e-300"),
            (m, "plastic_modulus_Pa", "range [1000, 1e+13)"),
        ),
        (
            "calibration_derives_huge_k",
            "[calibration]\nk_per_compliance = 1e10\n"
            + tin("plastic_modulus_Pa = 0.5e9", "plastic_modulus_Pa = 1e6"),
            (m, "plastic_modulus_Pa", "gives k", "range [0, 1000]"),
        ),
        (
            "calibration_1e308",
            "[calibration]\nk_per_compliance = 1e308\n",
            (m, "k_per_compliance", "range [0, 1e+10]"),
        ),
        (  # issue 46 item 8: the panel would show "tinlive" for this name
            "name_right_to_left_override",
            tin("[materials.tin]", '[materials."tin\u202eevil"]'),
            (m, "materials.'tin\\u202eevil'", "holds \\u202e"),
        ),
        (
            "name_too_long",
            tin("[materials.tin]", "[materials." + "t" * 65 + "]"),
            (m, "1 to 64 printable characters"),
        ),
        (
            "y_unit_1e308",
            "[calibration]\nY_unit_Ns = 1e308\n",
            (m, "Y_unit_Ns", "range (0, 1e+06]"),
        ),
    ]
    cases = [
        Case(f"materials-{name}", "materials", argv, {m: text}, reject=frag)
        for name, text, frag in table
    ]
    cases += [
        Case("materials-missing_file", "materials", argv, reject=(m, "no such file")),
        Case(
            "materials-empty_file_accepted",
            "materials",
            argv,
            {m: ""},
            accept=_materials_json("steel", "restitution", 0.6),
        ),
        Case(
            "materials-zero_calibration_accepted_as_no_dents",
            "materials",
            argv,
            {m: "[calibration]\nk_per_compliance = 0\n"},
            accept=_materials_json("steel", "k_m_per_Ns", 0.0),
        ),
        Case(
            "materials-override_accepted",
            "materials",
            argv,
            {m: _scene("[materials.tin]", "[materials.steel]", MATERIAL_OK)},
            accept=_materials_json("steel", "restitution", 0.3),
        ),
        Case(
            "materials-scene_uses_bad_file",
            "materials",
            ["simulate", "--scene", "s.toml", "--steps", "1", "--materials", m],
            {"s.toml": SCENE, m: _scene("friction = 0.5", "friction = -3", MATERIAL_OK)},
            reject=(m, "friction", "-3"),
        ),
    ]
    return cases


def flag_cases() -> list[Case]:
    files = {
        "s.toml": SCENE,
        "afile": "x",
        "sub/keep.txt": "x",
        # What a save killed between its renames leaves: no 'st', the previous state aside.
        ".st.k2j4x9ab.old/state.json": "{}",
    }
    table: list[tuple[str, list[str], tuple[str, ...]]] = [
        ("unknown_command", ["fly"], ("fly",)),
        ("unknown_flag", [*RENDER, "--bogus"], ("--bogus",)),
        ("frames_zero", [*RENDER[:-6], "--frames", "0", *RENDER[-4:]], ("--frames", "0")),
        ("frames_negative", [*RENDER, "--frames", "-5"], ("--frames", "-5")),
        ("frames_float", [*RENDER, "--frames", "2.5"], ("--frames", "2.5")),
        ("frames_text", [*RENDER, "--frames", "many"], ("--frames", "many")),
        ("frames_huge", [*RENDER, "--frames", "1000000000"], ("--frames", "1000000000")),
        ("size_word", [*RENDER, "--size", "big"], ("--size", "big")),
        ("size_zero", [*RENDER, "--size", "0x0"], ("--size", "0x0")),
        ("size_small", [*RENDER, "--size", "10x10"], ("--size", "10x10")),
        ("size_huge", [*RENDER, "--size", "100000x100"], ("--size", "100000x100")),
        ("size_half", [*RENDER, "--size", "1280x"], ("--size", "1280x")),
        ("out_missing", RENDER[:-2], ("--out",)),
        ("out_is_folder", [*RENDER, "--out", "."], ("--out", "'.'")),
        ("out_is_existing_folder", [*RENDER, "--out", "sub"], ("--out", "sub", "folder")),
        ("out_under_file", [*RENDER, "--out", "afile/x.png"], ("--out", "afile")),
        ("out_bad_pattern", [*RENDER, "--out", "out/x%q.png"], ("--out", "x%q.png")),
        ("maps_dir_is_file", [*RENDER, "--maps-dir", "afile"], ("--maps-dir", "afile")),
        ("save_state_is_file", [*RENDER, "--save-state", "afile"], ("--save-state", "afile")),
        ("load_state_missing", [*RENDER, "--load-state", "nostate"], ("--load-state", "nostate")),
        ("save_state_is_cwd", [*RENDER, "--save-state", "."], ("--save-state", "'.'")),
        ("save_state_other_files", [*RENDER, "--save-state", "sub"], ("--save-state", "keep.txt")),
        (
            "load_state_after_killed_save",
            [*RENDER, "--load-state", "st"],
            ("--load-state", "'st' is missing", ".st.k2j4x9ab.old"),
        ),
        ("load_state_not_state", [*RENDER, "--load-state", "."], ("state.json",)),
        ("view_five", [*RENDER, "--view", "5"], ("--view", "5")),
        ("render_scene_missing", [*RENDER, "--scene", "nope.toml"], ("nope.toml",)),
        ("steps_negative", [*SIMULATE, "--steps", "-1"], ("--steps", "-1")),
        ("steps_text", [*SIMULATE, "--steps", "lots"], ("--steps", "lots")),
        ("steps_float", [*SIMULATE, "--steps", "2.5"], ("--steps", "2.5")),
        ("simulate_no_scene", ["simulate", "--steps", "1"], ("--scene",)),
        ("depth_negative", [*INDENT, "--depth", "-1"], ("--depth", "-1")),
        ("depth_nan", [*INDENT, "--depth", "nan"], ("--depth", "nan")),
        ("depth_inf", [*INDENT, "--depth", "inf"], ("--depth", "inf")),
        ("depth_two_metres", [*INDENT, "--depth", "2"], ("--depth", "2")),
        ("tool_size_zero", [*INDENT, "--tool-size", "0"], ("--tool-size", "0")),
        ("tool_size_huge", [*INDENT, "--tool-size", "1e9"], ("--tool-size", "1e9")),
        ("target_size_zero", [*INDENT, "--target-size", "0"], ("--target-size", "0")),
        ("map_size_three", [*INDENT, "--map-size", "3"], ("--map-size", "3")),
        ("map_size_huge", [*INDENT, "--map-size", "100000"], ("--map-size", "100000")),
        ("tool_map_negative", [*INDENT, "--tool-map-size", "-5"], ("--tool-map-size", "-5")),
        ("tool_map_huge", [*INDENT, "--tool-map-size", "100000"], ("--tool-map-size", "100000")),
        ("normal_zero", [*INDENT, "--normal", "0", "0", "0"], ("--normal", "0.0")),
        ("normal_nan", [*INDENT, "--normal", "nan", "0", "0"], ("--normal", "nan")),
        ("repeat_zero", [*INDENT, "--repeat", "0"], ("--repeat", "0")),
        ("offset_far", [*INDENT, "--offset", "1e9", "0"], ("--offset", "1e9")),
        ("tool_cone", [*INDENT, "--tool", "cone"], ("--tool", "cone")),
        ("indent_out_is_file", [*INDENT, "--out", "afile"], ("--out", "afile")),
        ("pattern_missing", [*INDENT, "--tool-pattern", "nope.png"], ("nope.png",)),
        (
            "pattern_height_negative",
            [*INDENT, "--pattern-height", "-1"],
            ("--pattern-height", "-1"),
        ),
        ("max_dent_zero", [*INDENT, "--max-dent-depth", "0"], ("--max-dent-depth", "0")),
        ("press_misses", [*INDENT, "--offset", "5", "5"], ("--offset", "cannot reach")),
        ("press_points_away", [*INDENT, "--normal", "0", "1", "0"], ("--normal", "never meets")),
        ("exit_after_negative", ["demo", "--exit-after", "-1"], ("--exit-after", "-1")),
        ("select_unknown_body", ["demo", "--select", "nobody"], ("--select", "nobody")),
        (
            "screenshot_under_file",
            ["demo", "--screenshot", "afile/x.png"],
            ("--screenshot", "afile"),
        ),
        (
            "bench_json_under_file",
            ["bench", "--tiny", "--json", "afile/b.json"],
            ("--json", "afile"),
        ),
        ("bench_plot_is_folder", ["bench", "--tiny", "--plot", "sub"], ("--plot", "sub")),
        ("bench_frames_zero", ["bench", "--tiny", "--frames", "0"], ("--frames", "0")),
        ("info_backend_vulkan", ["info", "--backend", "vulkan"], ("--backend", "vulkan")),
        ("materials_extra_argument", ["materials", "extra"], ("extra",)),
        ("fov_zero", [*RENDER, "--fov", "0"], ("--fov", "0")),
        ("eye_two_values", [*RENDER, "--eye", "1", "2"], ("--eye",)),
        ("eye_is_target", [*RENDER, "--eye", "1", "1", "1", "--target", "1", "1", "1"], ("--eye",)),
        ("quality_ultra", [*RENDER, "--quality", "ultra"], ("--quality", "ultra")),
        ("demo_size_word", ["demo", "--size", "huge"], ("--size", "huge")),
        ("out_name_too_long", [*RENDER[:-1], "o" * 252 + ".png"], ("--out", "256 bytes")),
        ("video_name_too_long", [*RENDER, "--video", "v" * 252 + ".gif"], ("--video", "256")),
        ("out_percent_alone", [*RENDER[:-1], "out/a%.png"], ("--out", "a%.png", "%%")),
        # Issue 46 item 8 and issue 41 item 13: the suffix names the format written; a %s
        # pattern wrote r0.png while "wrote r%s.png" was reported; an empty path is no path.
        ("out_jpg", [*RENDER[:-1], "out/r.jpg"], ("--out", "r.jpg", ".png")),
        ("out_glb", [*RENDER[:-1], "out/r.glb"], ("--out", "r.glb", ".png")),
        ("out_string_pattern", [*RENDER[:-1], "out/r%s.png"], ("--out", "r%s.png", "%04d")),
        ("out_two_numbers", [*RENDER[:-1], "out/r%d_%d.png"], ("--out", "r%d_%d.png")),
        (
            "bench_json_gif",
            ["bench", "--tiny", "--json", "out/o.gif"],
            ("--json", "o.gif", ".json"),
        ),
        ("bench_plot_jpg", ["bench", "--tiny", "--plot", "out/p.jpg"], ("--plot", "p.jpg", ".png")),
        ("indent_render_jpg", [*INDENT, "--render", "out/r.jpg"], ("--render", "r.jpg", ".png")),
        ("screenshot_gif", ["demo", "--screenshot", "out/s.gif"], ("--screenshot", "s.gif")),
        ("video_png", [*RENDER, "--video", "out/v.png"], ("--video", "v.png", ".mp4")),
        ("gltf_empty", [*RENDER, "--gltf", ""], ("--gltf", "''")),
        ("load_state_empty", [*RENDER, "--load-state", ""], ("--load-state", "''")),
        ("save_state_empty", [*RENDER, "--save-state", ""], ("--save-state", "''")),
        ("maps_dir_empty", [*RENDER, "--maps-dir", ""], ("--maps-dir", "''")),
        ("screenshot_empty", ["demo", "--screenshot", ""], ("--screenshot", "''")),
        ("bench_json_empty", ["bench", "--tiny", "--json", ""], ("--json", "''")),
        ("out_empty", [*RENDER[:-1], ""], ("--out", "''")),
        ("indent_out_empty", [*INDENT[:-1], ""], ("--out", "''")),
    ]
    cases = [Case(f"flags-{name}", "flags", argv, files, reject=frag) for name, argv, frag in table]
    cases += [
        Case(
            "flags-render_accepted",
            "flags",
            [*RENDER, "--out", "out/%02d.png", "--frames", "2"],
            files,
            accept=_wrote("out/01.png"),
        ),
        Case(
            "flags-save_state_replaces_an_earlier_state_whole",
            "flags",
            [*RENDER, "--save-state", "prev"],
            {**files, "prev/state.json": "{}", "prev/old.npy": "x"},
            accept=_state_replaced("prev"),
        ),
        Case(
            "flags-render_literal_percent_accepted",
            "flags",
            [*RENDER[:-1], "out/100%%_x.png"],
            files,
            accept=_wrote("out/100%_x.png"),
        ),
        Case(
            "flags-render_pattern_with_literal_percent_accepted",
            "flags",
            [*RENDER[:-1], "out/%%%02d.png", "--frames", "2"],
            files,
            accept=_wrote("out/%01.png"),
        ),
        Case(
            "flags-demo_screenshot_alone_ends_after_3_s",
            "flags",
            ["demo", "--screenshot", "out/shot.png", "--size", "64x36"],
            files,
            env={"DISPLAY": None, "WAYLAND_DISPLAY": None},
            accept=_simulated_seconds(3.0, "out/shot.png", (64, 36)),
        ),
        Case(
            "flags-indent_depth_beyond_the_bound_is_clamped",
            "flags",
            # A 0.5 m block: thicker than the bound (a 2 cm plate would stop the dent at 2 cm).
            [*INDENT, "--depth", "0.5", "--max-dent-depth", "0.1", "--target", "box"]
            + ["--target-size", "0.5"],
            files,
            accept=_clamped_press(0.1),
        ),
        Case(
            "flags-indent_tool_map_size_accepted",
            "flags",
            [*INDENT, "--tool-map-size", "32"],
            files,
            accept=_wrote("out/press/summary.json"),
        ),
    ]
    return cases


def env_cases() -> list[Case]:
    files = {"s.toml": SCENE}
    info = ["info"]
    return [
        Case(
            "env-backend_unknown",
            "env",
            RENDER,
            files,
            env={"DENTDEMO_GL_BACKEND": "vulkan"},
            reject=("DENTDEMO_GL_BACKEND", "vulkan"),
        ),
        Case(
            "env-backend_unknown_info",
            "env",
            info,
            env={"DENTDEMO_GL_BACKEND": "bogus"},
            reject=("DENTDEMO_GL_BACKEND", "bogus"),
        ),
        Case(
            "env-glx_without_display",
            "env",
            info,
            env={"DENTDEMO_GL_BACKEND": "glx", "DISPLAY": None},
            reject=("GLX", "DISPLAY"),
        ),
        Case(
            "env-bench_window_without_display",
            "env",
            ["bench", "--tiny", "--window"],
            env={"DISPLAY": None, "WAYLAND_DISPLAY": None},
            reject=("--window", "DISPLAY"),
        ),
        Case(
            "env-glx_bad_display",
            "env",
            info,
            env={"DENTDEMO_GL_BACKEND": "glx", "DISPLAY": ":4242"},
            reject=("GLX",),
        ),
        Case(
            "env-backend_upper_case_accepted",
            "env",
            info,
            env={"DENTDEMO_GL_BACKEND": "EGL"},
            accept=_rendered_with("egl"),
        ),
        Case(
            "env-backend_empty_accepted",
            "env",
            info,
            env={"DENTDEMO_GL_BACKEND": ""},
            accept=_rendered_with("egl"),
        ),
        Case(
            "env-flag_beats_environment",
            "env",
            ["info", "--backend", "egl"],
            env={"DENTDEMO_GL_BACKEND": "bogus"},
            accept=_rendered_with("egl"),
        ),
        Case(
            "env-warnings_as_errors_still_one_line",
            "env",
            SIMULATE,
            {"s.toml": _mesh_scene("m.obj"), "m.obj": OBJ_TETRA},
            env={"PYTHONWARNINGS": "error"},
            accept=_one_warning("re-atlasing"),
        ),
    ]


def all_cases() -> list[Case]:
    return [
        *scene_cases(),
        *mesh_cases(),
        *bump_cases(),
        *materials_cases(),
        *flag_cases(),
        *env_cases(),
    ]
