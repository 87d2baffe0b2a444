"""Saving and resuming damage (`render --save-state/--load-state`): a run stopped, saved, loaded
and continued is bit-identical to a run that never stopped; a bad state folder gets one line and
changes nothing."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from dentdemo.app.headless import render_headless
from dentdemo.errors import DentdemoError
from dentdemo.resources import assets_dir

BALL_DROP = assets_dir() / "scenes" / "ball_drop.toml"
SIZE = (320, 180)
#: Frames before the save, and as many after the load. ball_drop's balls first hit at frame 19
#: and keep hitting until about frame 60 (`dentdemo simulate --steps 240` lists them): the save
#: lands in the middle of the first bounces, with dents made and balls in flight, and the
#: resumed half carves the second bounces.
HALF = 30


def _heights(folder: Path) -> dict[str, np.ndarray]:
    return {p.name: np.load(p) for p in sorted(folder.glob("*_height.npy"))}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """2 x HALF frames in one run; HALF frames, save, load, HALF more."""
    root = tmp_path_factory.mktemp("state")
    render_headless(BALL_DROP, [], 2 * HALF, root / "whole.png", SIZE, maps_dir=root / "whole")
    render_headless(BALL_DROP, [], HALF, root / "half.png", SIZE, save_state=root / "saved")
    render_headless(
        BALL_DROP,
        [],
        HALF,
        root / "resumed.png",
        SIZE,
        maps_dir=root / "resumed",
        load_state=root / "saved",
    )
    return root


@pytest.mark.slow
def test_resumed_run_is_bit_identical(runs):
    whole, resumed = _heights(runs / "whole"), _heights(runs / "resumed")
    assert len(whole) == 14 and whole.keys() == resumed.keys()
    dented = 0
    for name in whole:
        assert whole[name].dtype == np.float32
        assert np.array_equal(whole[name], resumed[name]), name
        dented += int((whole[name] < -1e-6).any())
    assert dented >= 8  # the comparison covers real damage, not pristine maps
    # Dents were made before the save and after the load: the resumed frames carved on top of
    # loaded damage.
    saved = {p.name.removesuffix(".npy"): np.load(p) for p in (runs / "saved").glob("*.npy")}
    assert sum(int((h < -1e-6).any()) for h in saved.values()) >= 8
    grew = [n for n in whole if not np.array_equal(whole[n], saved[n.removesuffix("_height.npy")])]
    assert len(grew) >= 4
    a = np.asarray(Image.open(runs / "whole.png"))
    b = np.asarray(Image.open(runs / "resumed.png"))
    assert a.shape == (180, 320, 3) and np.array_equal(a, b)
    # ...and the saved half-way state is not the end state (the resumed frames did something).
    half = np.asarray(Image.open(runs / "half.png"))
    assert not np.array_equal(half, a)


def test_state_folder_holds_what_the_format_says(runs):
    state = json.loads((runs / "saved" / "state.json").read_text())
    assert state["format"] == "dentdemo-state" and state["version"] == 1
    dt = 1.0 / 60.0  # ball_drop.toml: dt = 1/60 s (checked below against the scene)
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene

    assert load_scene(BALL_DROP, load_materials()).physics.dt == pytest.approx(dt)
    assert state["world"]["time"] == pytest.approx(HALF * dt, rel=1e-9)
    assert state["world"]["step_index"] == HALF
    for body_id, entry in state["maps"].items():
        height = np.load(runs / "saved" / entry["file"])
        assert height.dtype == np.float32 and list(height.shape) == entry["shape"], body_id


def _broken(runs: Path, tmp_path: Path, how: str) -> Path:
    folder = tmp_path / how
    shutil.copytree(runs / "saved", folder)
    state_file = folder / "state.json"
    state = json.loads(state_file.read_text())
    if how == "truncated_map":
        target = folder / "steel_plate.npy"
        target.write_bytes(target.read_bytes()[:-100])
    elif how == "missing_map":
        (folder / "lead_plate.npy").unlink()
    elif how == "version":
        state["version"] = 99
    elif how == "scene":
        state["scene"]["sha256"] = "0" * 64
    elif how == "not_json":
        state_file.write_text("{ not json")
        return folder
    elif how == "no_state":
        state_file.unlink()
        return folder
    elif how == "unknown_body":
        state["world"]["order"].append("ghost")
    state_file.write_text(json.dumps(state))
    return folder


@pytest.mark.parametrize(
    "how,fragment",
    [
        ("truncated_map", "steel_plate.npy"),
        ("missing_map", "lead_plate.npy"),
        ("version", "version is 99"),
        ("scene", "differs from"),
        ("not_json", "state.json"),
        ("no_state", "state.json"),
        ("unknown_body", "ghost"),
    ],
)
def test_bad_state_is_one_line_and_changes_nothing(gl, runs, tmp_path, how, fragment):
    from dentdemo.app.simulation import Simulation
    from dentdemo.app.state import load_state
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene

    folder = _broken(runs, tmp_path, how)
    lib = load_materials()
    sim = Simulation(gl, load_scene(BALL_DROP, lib), lib)
    try:
        for _ in range(3):
            sim.step()
        before = {k: gl.read(b.maps.height).copy() for k, b in sim.bodies.items()}
        poses = {k: sim.world.pose(k) for k in sim.bodies}
        time = sim.world.time
        with pytest.raises(DentdemoError) as info:
            load_state(sim, folder)
        message = str(info.value)
        assert fragment in message and "\n" not in message
        assert sim.world.time == time
        for k, b in sim.bodies.items():
            assert np.array_equal(gl.read(b.maps.height), before[k])
            assert all(
                np.array_equal(x, y) for x, y in zip(sim.world.pose(k), poses[k], strict=True)
            )
    finally:
        sim.close()


@pytest.mark.slow
def test_demo_save_and_load_keys_restore_added_bodies(gl, tmp_path):
    """The demo's F5/F9 (panel buttons): a ball dropped by the user is saved with its damage and
    comes back on load, after the run went on and the user dropped another."""
    from dentdemo.app.controller import DemoController
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene

    lib = load_materials()
    app = DemoController(gl, load_scene(BALL_DROP, lib), lib, (160, 90))
    try:
        dropped = app.tools.drop_ball(0.0, 0.0)
        assert dropped is not None
        for _ in range(90):
            app.sim.step()
        assert app.state.save(tmp_path / "s"), app.message
        saved_heights = {k: gl.read(b.maps.height).copy() for k, b in app.sim.bodies.items()}
        saved_pose = app.sim.world.pose(dropped)
        saved_time = app.sim.world.time
        app.tools.drop_ball(0.3, 0.1)
        for _ in range(30):
            app.sim.step()
        assert app.state.load(tmp_path / "s"), app.message
        assert set(app.sim.bodies) == set(saved_heights)  # the second ball is gone
        assert app.sim.world.time == saved_time
        assert all(
            np.array_equal(a, b)
            for a, b in zip(app.sim.world.pose(dropped), saved_pose, strict=True)
        )
        for k, b in app.sim.bodies.items():
            assert np.array_equal(gl.read(b.maps.height), saved_heights[k]), k
        assert not app.state.load(tmp_path / "nothing_here")
        assert "nothing_here" in app.message
    finally:
        app.close()
