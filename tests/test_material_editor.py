"""The panel's material editor (issue 23, item 2), through the controller: every key editable in
the validator's ranges, k and Y live, the predicted dent against a hand computation, and "save
to file" keeping the user's comments and order, never the shipped presets."""

from __future__ import annotations

import dataclasses
import hashlib
import math
import tomllib
from pathlib import Path

import pytest

from dentdemo.app.controller import DemoController
from dentdemo.app.editor import predict_dent
from dentdemo.app.materials_save import save_preset
from dentdemo.errors import DentdemoError
from dentdemo.model.materials import builtin_materials_path, load_materials
from dentdemo.model.materials_keys import MATERIAL_NUMBERS
from dentdemo.model.scene import load_scene
from scene_text import GROUND, TIN, plate

ROOT = Path(__file__).resolve().parents[1]
SCENE = GROUND + "\n" + plate("steel", texels=256)

USER = (
    """# My presets. This comment, the order and the spelling of untouched numbers must survive.

[materials.steel]  # overriding the shipped steel
youngs_modulus_Pa = 200e9
yield_stress_Pa = 250e6
plastic_modulus_Pa = 2.0e9
density_kg_m3 = 7850
restitution = 0.6     # keep this note
friction = 0.6
max_dent_depth_m = 0.01

"""
    + TIN
)


def _app(gl, tmp_path: Path, user: Path | None = None) -> DemoController:
    scene_path = tmp_path / "plate.toml"
    scene_path.write_text(SCENE)
    files = [user] if user else []
    lib = load_materials(files)
    app = DemoController(gl, load_scene(scene_path, lib), lib, (64, 36))
    app.reload.watch(files, scene_path)
    return app


def test_the_editor_shows_the_validators_ranges():
    """The ranges the panel shows are those the README documents for the materials file."""
    documented = {
        "youngs_modulus_Pa": "[10000, 1e+13]",
        "yield_stress_Pa": "[1000, 1e+11]",
        "plastic_modulus_Pa": "[1000, 1e+13), < E",
        "density_kg_m3": "[0.1, 100000]",
        "restitution": "[0, 1)",
        "friction": "[0, 10]",
        "max_dent_depth_m": "(0, 1]",
        "k_m_per_Ns": "[0, 1000]",
        "rolling_friction": "[0, 1]",
        "wear_coefficient": "[0, 1]",
        "hardness_Pa": "[1000, 3e+11]",
        "metalness": "[0, 1]",
        "roughness": "[0.02, 1]",
        "coat_thickness_m": "[0, 0.01]",
        "coat_metalness": "[0, 1]",
        "coat_wear_coefficient": "[0, 1]",
        "coat_hardness_Pa": "[1000, 3e+11]",
        "coat_roughness": "[0.02, 1]",
    }
    assert {k.key: k.range_text() for k in MATERIAL_NUMBERS} == documented
    # ... and the validator holds each bound: just past it is refused, the bound itself as the
    # interval says.
    lib = load_materials()
    for spec in MATERIAL_NUMBERS:
        for bound, inclusive, past in (
            (spec.low, spec.low_inclusive, -math.inf),
            (spec.high, spec.high_inclusive, math.inf),
        ):
            if bound is None:
                continue
            table = {
                "youngs_modulus_Pa": 200e9,
                "yield_stress_Pa": 250e6,
                "plastic_modulus_Pa": 2e9,
                "density_kg_m3": 7850,
                "restitution": 0.6,
                "friction": 0.6,
                "max_dent_depth_m": 0.01,
            }
            from dentdemo.model.materials import parse_material

            if spec.key == "youngs_modulus_Pa" and past < 0:
                table["plastic_modulus_Pa"] = 1e3  # below E at E's lower bound
            table[spec.key] = math.nextafter(bound, past)
            with pytest.raises(DentdemoError, match=spec.key):
                parse_material("t", "m", table, lib.calibration)
            table[spec.key] = bound
            if inclusive:
                parse_material("t", "m", table, lib.calibration)
            else:
                with pytest.raises(DentdemoError, match=spec.key):
                    parse_material("t", "m", table, lib.calibration)


def test_predicted_dent_is_eqs_2_to_5_by_hand():
    lib = load_materials()
    steel, aluminium = lib.materials["steel"], lib.materials["aluminium"]
    r, v = 0.04, 6.0
    # By hand from assets/materials.toml: m = rho 4/3 pi r^3; eq. 2 with eps = 1 onto a static
    # plate: j = 2 m v; eq. 3: k = 2e5 (1/P - 1/E); eq. 5: Y = 1/(1 - eps) - 1; eq. 4.
    m = 7850 * 4 / 3 * math.pi * r**3  # 2.1043 kg
    j = 2 * m * v  # 25.25 N*s
    k_al = 2e5 * (1 / 0.7e9 - 1 / 69e9)
    y_al = 1 / (1 - 0.5) - 1
    k_st = 2e5 * (1 / 2.0e9 - 1 / 200e9)
    y_st = 1 / (1 - 0.6) - 1
    dent = predict_dent(steel, r, v, aluminium)
    assert dent.j_elastic == pytest.approx(j, rel=1e-12)
    assert dent.plate_m == pytest.approx(k_al * (j - y_al), rel=1e-12)  # 6.86 mm
    assert dent.ball_m == pytest.approx(k_st * (j - y_st), rel=1e-12)  # 2.35 mm
    assert not dent.plate_bound and not dent.ball_bound
    # A lead plate would take k (j - Y) = 17 mm... at 10 m/s, 28 mm: its bound 30 mm is not hit;
    # clay at any real throw is clamped to its 30 mm bound.
    clay = predict_dent(steel, r, v, lib.materials["clay"])
    assert clay.plate_m == 0.03 and clay.plate_bound
    # ... and a 2 cm clay plate (the panel's) to its thickness: no dent goes through a body.
    thin = predict_dent(steel, r, v, lib.materials["clay"], plate_thickness=0.02)
    assert thin.plate_m == 0.02 and thin.plate_bound
    # A 5 mm ball of a clay ten times softer (k = 0.1 m/(N*s)) thrown into steel at 300 m/s
    # (k (j - Y) = 57 mm): bounded by its own 10 mm across, not clay's 30 mm.
    softer = dataclasses.replace(lib.materials["clay"], k=0.1)
    ball = predict_dent(softer, 0.005, 300.0, steel)
    assert ball.ball_m == pytest.approx(0.01) and ball.ball_bound
    # Below the threshold: a 1 cm ball at 0.5 m/s (j = 0.033 N*s < Y of steel, 1.5 N*s).
    assert predict_dent(steel, 0.01, 0.5, steel).plate_m == 0.0


def test_the_panel_lists_a_dent_per_plate_material(gl, tmp_path):
    app = _app(gl, tmp_path)
    try:
        app.panel.ball_material, app.panel.ball_radius, app.panel.throw_speed = "steel", 0.04, 6.0
        dents = {d.plate_material: d for d in app.editor.predicted_dents()}
        assert sorted(dents) == app.sim.materials.names()
        k_al = 2e5 * (1 / 0.7e9 - 1 / 69e9)
        j = 2 * 7850 * 4 / 3 * math.pi * 0.04**3 * 6.0
        assert dents["aluminium"].plate_m == pytest.approx(k_al * (j - 1.0), rel=1e-12)
    finally:
        app.close()


def test_an_edit_is_used_at_once_with_k_and_y_following(gl, tmp_path):
    app = _app(gl, tmp_path)
    try:
        app.editor.material.select(app.sim.materials, "steel")
        assert app.editor.edit("plastic_modulus_Pa", 1.0e9)
        assert app.editor.edit("restitution", 0.2)
        preset = app.editor.material.preset
        assert preset.k == pytest.approx(2e5 * (1 / 1.0e9 - 1 / 200e9), rel=1e-12)
        assert preset.Y == pytest.approx(1 / (1 - 0.2) - 1, rel=1e-12)
        # The plate (steel) and a new ball use it, and the prediction follows.
        assert app.sim.bodies["plate"].spec.material == preset
        ball = app.sim.drop_ball((0, 0.3, 0), material="steel")
        assert app.sim.bodies[ball].spec.material == preset
        app.panel.ball_material = "steel"
        steel_plate = next(d for d in app.editor.predicted_dents() if d.plate_material == "steel")
        j = 2 * 7850 * 4 / 3 * math.pi * 0.04**3 * app.panel.throw_speed
        assert steel_plate.plate_m == pytest.approx(preset.k * (j - preset.Y), rel=1e-12)
        # An explicit k, then derived again.
        assert app.editor.edit("k_m_per_Ns", 1e-4) and app.editor.material.preset.k == 1e-4
        assert app.editor.edit("k_m_per_Ns", None) and not app.editor.material.preset.k_explicit
        # Invalid: the validator's line, the last valid preset stays in use.
        before = app.editor.material.preset
        assert not app.editor.edit("restitution", 1.0)
        assert app.editor.material.error.startswith(
            "material editor: [materials.steel] key 'restitution' = 1.0: must be < 1 (range [0, 1)"
        )
        assert app.editor.material.preset == before == app.sim.bodies["plate"].spec.material
        assert app.editor.edit("restitution", 0.2)  # mended: valid again
        assert not app.editor.edit("density_kg_m3", 1e200)  # issue 46: ODE cannot hold it
        assert "range [0.1, 100000] kg/m^3" in app.editor.material.error
        assert app.editor.edit("density_kg_m3", 7850.0), app.editor.material.error
        assert not app.editor.edit("plastic_modulus_Pa", 300e9)
        assert "plastic_modulus_Pa" in app.editor.material.error
        assert app.editor.edit("plastic_modulus_Pa", 1.0e9), app.editor.material.error
    finally:
        app.close()


def test_save_keeps_comments_and_order_and_changes_only_the_edited_line(gl, tmp_path):
    user = tmp_path / "mine.toml"
    user.write_text(USER)
    app = _app(gl, tmp_path, user)
    try:
        app.editor.material.select(app.sim.materials, "steel")
        assert app.editor.edit("restitution", 0.25)
        assert app.editor.save(), app.message
        text = user.read_text()
        expected = USER.replace("restitution = 0.6     # keep", "restitution = 0.25     # keep")
        assert text == expected
        assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no temp
        assert tomllib.loads(text)["materials"]["steel"]["restitution"] == 0.25
        # A shipped preset saved into the user file: appended whole, the file still loads.
        app.editor.material.select(app.sim.materials, "copper")
        assert app.editor.edit("friction", 0.45)
        assert app.editor.save()
        assert user.read_text().startswith(expected)
        assert load_materials([user]).materials["copper"].friction == 0.45
        # The watcher sees the save as any other: the library reloads from the file.
        app.reload.poll(100.0)
        assert app.reload.poll(101.0) == [f"dentdemo: reloaded {user} (3 materials)"]
    finally:
        app.close()


def test_save_without_a_user_file_never_writes_the_shipped_presets(gl, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shipped = builtin_materials_path()
    before = hashlib.sha256(shipped.read_bytes()).hexdigest()
    app = _app(gl, tmp_path)
    try:
        app.editor.material.select(app.sim.materials, "lead")
        assert app.editor.edit("density_kg_m3", 11000.0)
        assert app.editor.save()
        written = tmp_path / "dentdemo_materials.toml"
        assert load_materials([written]).materials["lead"].density == 11000.0
        assert app.reload.material_files == (Path("dentdemo_materials.toml"),)
    finally:
        app.close()
    assert hashlib.sha256(shipped.read_bytes()).hexdigest() == before
    table = {"youngs_modulus_Pa": 1e9}
    with pytest.raises(DentdemoError, match="shipped presets are never written"):
        save_preset(shipped, "lead", table, load_materials().calibration)


def test_save_into_a_malformed_file_is_one_error_and_writes_nothing(gl, tmp_path):
    user = tmp_path / "mine.toml"
    user.write_text(USER)
    app = _app(gl, tmp_path, user)
    try:
        user.write_text(USER + "\n[oops\n")
        app.editor.material.select(app.sim.materials, "steel")
        assert app.editor.edit("friction", 0.7)
        assert not app.editor.save()
        assert app.message.startswith(f"{user}: malformed TOML")
        assert user.read_text() == USER + "\n[oops\n"
        # An invalid draft is never written either.
        user.write_text(USER)
        app.editor.edit("friction", 11.0)
        assert not app.editor.save()
        assert "friction" in app.message and user.read_text() == USER
    finally:
        app.close()
