"""The demo's feature controllers (app/controllers/), driven without a window: each is small,
owns its keys, and works on a Simulation alone; the coordinator dispatches a key to the one
feature that has it, and shows the real rate when the world falls behind real time."""

from __future__ import annotations

import ast
import re
import time
from pathlib import Path

import pytest

from dentdemo.app.controller import DemoController
from dentdemo.app.controllers.export import ExportController
from dentdemo.app.controllers.undo import UndoController
from dentdemo.app.simulation import Simulation
from dentdemo.app.status import Status
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
BALL_DROP = ROOT / "assets" / "scenes" / "ball_drop.toml"
APP = ROOT / "src" / "dentdemo" / "app"
MOST_METHODS = 15


@pytest.fixture
def app(ball_drop_app) -> DemoController:
    return ball_drop_app


def test_no_controller_class_has_more_than_15_methods():
    """Counted in the source: every function a class body defines (properties too)."""
    files = [APP / "controller.py", *sorted((APP / "controllers").glob("*.py"))]
    counted = {}
    for path in files:
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.ClassDef) and node.name.endswith("Controller"):
                defs = [n for n in node.body if isinstance(n, ast.FunctionDef)]
                counted[node.name] = len(defs)
    assert len(counted) == 9, counted  # the coordinator and eight features
    assert max(counted.values()) <= MOST_METHODS, counted


def test_each_key_is_one_features_and_the_readme_lists_it(app):
    keys = app.keys()
    features = [app.view, app.reload, app.editor, app.state, app.undo, app.export, app.tools]
    owned = [name for feature in (*features, app.recording) for name in feature.keys()]
    assert len(owned) == len(set(owned))  # no key is two features'
    assert {"space", "n", "r"} | set(owned) == set(keys)
    text = (ROOT / "README.md").read_text()
    rows = text[text.index("| input | action |") :].split("\n\n")[0].splitlines()[2:]
    first_column = " ".join(row.split("|")[1] for row in rows)
    for name in keys:
        shown = {"space": "Space", "ctrl+z": "Ctrl+Z"}.get(name, name.upper())
        assert re.search(rf"(?<![\w+]){re.escape(shown)}\b", first_column), name


def test_a_key_runs_its_features_action(app, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    dt = app.sim.scene.physics.dt
    assert app.press("space") and app.paused
    assert app.press("n") and app.sim.world.time == pytest.approx(dt)
    assert app.press("2") and app.view.options.view == 1
    assert app.press("w") and app.view.options.wireframe
    assert app.press("ctrl+z") and app.message == "nothing to undo"
    assert app.press("f5") and app.message.startswith("saved to dentdemo_state/")
    assert (tmp_path / "dentdemo_state" / "state.json").is_file()
    assert app.press("f9") and app.message.startswith("loaded dentdemo_state/")
    assert app.press("g") and (tmp_path / "dentdemo.glb").is_file()
    assert not app.press("q")  # nobody's key


def test_the_window_opens_with_the_main_panel_only(app):
    """First sight: the material editor and the developer tools open from their keys (E, D)
    and close again; a Ctrl + click selection opens the tools."""
    assert not app.editor.visible and not app.tools.visible
    assert app.press("e") and app.editor.visible
    assert app.press("e") and not app.editor.visible
    assert app.press("d") and app.tools.visible
    app.press("d")
    assert app.tools.select_at(0.0, -0.6) is not None and app.tools.visible


def test_the_panel_shows_the_real_rate_when_the_world_falls_behind(app):
    """Frames of 0.2 s owe 12 steps of 1/60 s each, and a frame takes at most 4: the world runs
    at 4/60 s per 0.2 s, a third of real time, which the panel says instead of the 1.00 x set;
    frames of 1/60 s keep up."""
    dt = app.sim.scene.physics.dt
    for _ in range(10):
        app.update(0.2)
    assert app.rate.rate() == pytest.approx(4 * dt / 0.2, rel=1e-9)
    text = app.rate.text(app.sim.time_scale, app.paused)
    assert text.startswith("runs at 0.33 x real time") and "behind the 1.00 x set" in text
    for _ in range(66):  # over a second of them: the slow frames leave the rate's window
        app.update(dt)
    assert app.rate.rate() == pytest.approx(1.0, rel=0.02)
    assert "behind" not in app.rate.text(app.sim.time_scale, app.paused)
    app.toggle_pause()
    assert app.rate.text(app.sim.time_scale, app.paused) == "paused"


def test_fixed_step_frames_measure_the_rate_too(app):
    """--exit-after and a recording step one dt a frame: the rate is the scene's dt over each
    frame's wall time, never the time scale set (before a frame: nothing is claimed)."""
    from dentdemo.app.loop import FrameLoop, ImageBackend

    assert app.rate.text(app.sim.time_scale, app.paused) == "rate: measuring"
    before = time.perf_counter()
    loop = FrameLoop(app, ImageBackend((64, 36), None), fixed_dt=True)
    after = time.perf_counter()
    for _ in range(3):
        loop.frame()
    third = time.perf_counter()
    loop.frame()
    fourth = time.perf_counter()
    # A frame's wall time runs from the frame before's start (the first's from the loop's
    # making): four frames' span from the loop's making to the fourth frame's start.
    dt = app.sim.scene.physics.dt
    assert 4 * dt / (fourth - before) <= app.rate.rate() <= 4 * dt / (third - after)


def test_features_work_on_a_simulation_alone(gl, tmp_path):
    """No coordinator, no window: a Simulation and a status line."""
    lib = load_materials()
    sim = Simulation(gl, load_scene(BALL_DROP, lib), lib)
    try:
        status = Status()
        undo, export = UndoController(sim, status), ExportController(sim, status)
        assert not undo.undo() and status.line == "nothing to undo"
        while sim.last_hit is None:
            sim.step()
        deepest = undo.repair_target()
        assert deepest == sim.last_hit.deepest()[0]
        assert undo.undo() and status.line.startswith("undid the last hits")
        assert export.gltf(tmp_path / "now.glb") and (tmp_path / "now.glb").stat().st_size > 0
        assert status.line.startswith(f"exported {tmp_path / 'now.glb'} at t = ")
        assert not export.gltf(tmp_path / "no" / "such" / "folder" / "x.txt")
        assert "x.txt" in status.line
    finally:
        sim.close()
