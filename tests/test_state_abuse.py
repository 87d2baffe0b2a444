"""Saved state under abuse: every damaged value of state.json is one line naming state.json, the
key and the value, before anything is reset (all or nothing, in the CLI and in the demo's F9);
nothing a load would refuse is saved; a save is swapped in as a whole, so a kill at any step
leaves the previous state or the new one."""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dentdemo.errors import DentdemoError
from dentdemo.resources import assets_dir

BALL_DROP = assets_dir() / "scenes" / "ball_drop.toml"
STEPS = 45  # 0.75 s at the scene's 1/60 s: the scene's balls have hit, their carves queued


def _sim(gl, carve_budget: int = 16):
    from dentdemo.app.simulation import Simulation
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene

    lib = load_materials()
    return Simulation(gl, load_scene(BALL_DROP, lib), lib, carve_budget=carve_budget)


@pytest.fixture(scope="module")
def saved(gl_session, tmp_path_factory) -> Path:
    """A state with an added ball and queued carves (a carve budget of 0 keeps every hit)."""
    from dentdemo.app.state import save_state

    folder = tmp_path_factory.mktemp("abuse") / "saved"
    gl_session.make_current()  # tests before may have made and released contexts of their own
    sim = _sim(gl_session, carve_budget=0)
    try:
        sim.drop_ball((0.6, 0.5, 0.6))
        for _ in range(STEPS):
            sim.step()
        assert len(sim.queue) >= 3  # the queue cases below have entries to break
        save_state(sim, folder)
    finally:
        sim.close()
    return folder


def _state(folder: Path) -> dict:
    return json.loads((folder / "state.json").read_text())


def _moving(state: dict) -> str:
    """A scene body that moves (a ball of ball_drop.toml)."""
    assert "steel_ball" in state["world"]["bodies"]
    return "steel_ball"


def _break(state: dict, folder: Path, how: str) -> None:
    world, bodies = state["world"], state["world"]["bodies"]
    ball = _moving(state)
    if how == "quaternion_nan":
        bodies[ball][1][0] = math.nan
    elif how == "quaternion_huge":
        bodies[ball][1] = [1e300, 0.0, 0.0, 0.0]
    elif how == "quaternion_zero":
        bodies[ball][1] = [0.0, 0.0, 0.0, 0.0]
    elif how == "position_inf":
        bodies[ball][0][1] = math.inf
    elif how == "time_text":
        world["time"] = "abc"
    elif how == "time_nan":
        world["time"] = math.nan
    elif how == "time_huge_int":
        world["time"] = 10**400
    elif how == "model_huge_int":
        state["queue"][0]["model_a"][0][0] = 10**400
    elif how == "nested_deep":
        (folder / "state.json").write_text("[" * 100000 + "]" * 100000)
        raise _Written
    elif how == "time_far":
        world["time"] = 1e300
    elif how == "seed_negative":
        world["seed"] = -1
    elif how == "ball_count_text":
        state["ball_count"] = "x"
    elif how == "extra_body":
        bodies["ghost_ball"] = bodies[ball]
    elif how == "short_body_entry":
        bodies[ball] = bodies[ball][:3]
    elif how == "short_position":
        bodies[ball][0] = bodies[ball][0][:2]
    elif how == "missing_from_order":
        world["order"].remove(ball)
    elif how == "added_missing_from_order":
        world["order"].remove("ball_1")
    elif how == "order_twice":
        world["order"].append(world["order"][0])
    elif how == "moving_body_missing":
        del bodies[ball]
    elif how == "queue_point_short":
        state["queue"][0]["impact"]["point"] = [1.0, 2.0]
    elif how == "queue_entry_text":
        state["queue"][1] = "junk"
    elif how == "queue_unknown_body":
        state["queue"][0]["impact"]["body_b"] = "nobody"
    elif how == "queue_depth_nan":
        state["queue"][2]["depth_a"] = math.nan
    elif how == "queue_model_nan":
        state["queue"][0]["model_b"][0][0] = math.nan
    elif how == "stats_hits_text":
        state["stats"]["hits"] = "lots"
    elif how == "stats_unknown":
        state["stats"]["bogus"] = 1
    elif how == "added_radius_zero":
        state["added_bodies"][0]["shape"]["radius"] = 0.0
    elif how == "added_radius_huge":
        state["added_bodies"][0]["shape"]["radius"] = 1000.0
    elif how == "added_material":
        state["added_bodies"][0]["material"] = "cheese"
    elif how == "added_id_path":
        state["added_bodies"][0]["id"] = "../x"
    elif how == "map_extra":
        state["maps"]["ghost"] = dict(state["maps"]["steel_plate"])
    elif how == "map_missing_entry":
        del state["maps"]["steel_plate"]
    elif how == "carved_point_nan":
        state["carved_points"] = [[math.nan, 0.0, 0.0]]
    elif how == "ball_count_5000_digits":  # issue 46: a 27-line ValueError traceback
        text = json.dumps({**state, "ball_count": 7}).replace(
            '"ball_count": 7', '"ball_count": ' + "9" * 5000
        )
        (folder / "state.json").write_text(text)
        raise _Written
    elif how == "stale_state_json":  # a complete map whose bytes are not the ones listed
        target = folder / "steel_plate.npy"
        height = np.load(target)
        np.save(target, np.zeros_like(height) - 1e-4)
    else:
        raise AssertionError(how)


#: (how, fragments of the one line, beside the state.json path that every line starts with).
CASES = [
    ("quaternion_nan", ("steel_ball", "'quaternion' = [nan")),
    ("quaternion_huge", ("steel_ball", "'quaternion' = [1e+300", "unit quaternion")),
    ("quaternion_zero", ("steel_ball", "'quaternion'", "length is 0")),
    ("position_inf", ("steel_ball", "'position'", "finite")),
    ("time_text", ("[world] key 'time' = 'abc'", "number")),
    ("time_nan", ("[world] key 'time' = nan", "finite")),
    ("time_huge_int", ("[world] key 'time' = 1000000000", "finite")),
    ("model_huge_int", ("[queue[0]] key 'model_a'", "finite")),
    ("nested_deep", ("not a readable state file (RecursionError)",)),
    ("time_far", ("[world] key 'time' = 1e+300", "step_index x dt")),
    ("seed_negative", ("[world] key 'seed' = -1",)),
    ("ball_count_text", ("key 'ball_count' = 'x'", "integer")),
    ("extra_body", ("[world.bodies] key 'ghost_ball'",)),
    ("short_body_entry", ("[world.bodies] key 'steel_ball'", "must be a list [position")),
    ("short_position", ("[world.bodies.steel_ball] key 'position'", "3 numbers")),
    ("missing_from_order", ("[world.bodies] key 'steel_ball'", "not a moving body")),
    ("added_missing_from_order", ("[world] key 'order'", "'ball_1' is missing")),
    ("order_twice", ("[world] key 'order'", "listed twice")),
    ("moving_body_missing", ("[world.bodies]", "missing key 'steel_ball'")),
    ("queue_point_short", ("[queue[0].impact] key 'point' = [1.0, 2.0]",)),
    ("queue_entry_text", ("[queue[1]]", "'junk'")),
    ("queue_unknown_body", ("[queue[0].impact] key 'body_b' = 'nobody'",)),
    ("queue_depth_nan", ("[queue[2]] key 'depth_a' = nan",)),
    ("queue_model_nan", ("[queue[0]] key 'model_b'", "finite")),
    ("stats_hits_text", ("[stats] key 'hits' = 'lots'",)),
    ("stats_unknown", ("[stats] key 'bogus'", "unknown key")),
    ("added_radius_zero", ("[added_bodies[0].shape] key 'radius' = 0.0",)),
    ("added_radius_huge", ("[added_bodies[0].shape] key 'radius' = 1000.0", "<= 100")),
    ("added_material", ("added_bodies[0]", "cheese")),
    ("added_id_path", ("[added_bodies[0]] key 'id' = '../x'",)),
    ("map_extra", ("[maps] key 'ghost'",)),
    ("map_missing_entry", ("[maps]", "missing key 'steel_plate'")),
    ("carved_point_nan", ("[carved_points[0]] key 'point'", "finite")),
    ("stale_state_json", ("[maps.steel_plate] key 'sha256'", "state.json is stale")),
    ("ball_count_5000_digits", ("not a readable state file (a number of more than 4300 digits)",)),
]


class _Written(Exception):
    """_break wrote state.json itself."""


def _broken(saved: Path, tmp_path: Path, how: str) -> Path:
    folder = tmp_path / how
    shutil.copytree(saved, folder)
    state = _state(folder)
    try:
        _break(state, folder, how)
    except _Written:
        return folder
    (folder / "state.json").write_text(json.dumps(state))
    return folder


def _fingerprint(gl, sim) -> tuple:
    """Everything a load sets: time, bodies with poses and maps, queue, counters."""
    return (
        sim.world.time,
        sim.world.step_index,
        {k: [np.asarray(x).tolist() for x in sim.world.pose(k)] for k in sim.world.bodies},
        {k: gl.read(b.maps.height).tobytes() for k, b in sim.bodies.items()},
        len(sim.queue),
        sim.stats.hits,
        sim.ball_count,
    )


@pytest.mark.parametrize("how,fragments", CASES, ids=[c[0] for c in CASES])
@pytest.mark.slow
def test_damaged_state_is_one_line_and_changes_nothing(gl, saved, tmp_path, how, fragments):
    from dentdemo.app.state import load_state

    folder = _broken(saved, tmp_path, how)
    sim = _sim(gl)
    try:
        sim.drop_ball((0.3, 0.4, 0.2))  # a body the load would remove
        for _ in range(3):
            sim.step()
        before = _fingerprint(gl, sim)
        with pytest.raises(DentdemoError) as info:
            load_state(sim, folder)
        message = str(info.value)
        assert "\n" not in message
        assert message.startswith(str(folder / "state.json")), message
        for fragment in fragments:
            assert fragment in message, (fragment, message)
        assert _fingerprint(gl, sim) == before
        sim.step()  # ...and it still runs
        assert math.isfinite(sim.world.time)
    finally:
        sim.close()


@pytest.mark.slow
def test_the_saved_state_itself_loads_and_keeps_every_entry(gl, saved):
    """The undamaged folder the cases start from loads: the checks refuse damage, not states."""
    from dentdemo.app.state import load_state

    state = _state(saved)
    sim = _sim(gl)
    try:
        load_state(sim, saved)
        assert sim.world.step_index == STEPS and "ball_1" in sim.bodies
        assert len(sim.queue) == len(state["queue"]) >= 3
        assert sim.ball_count == 1 and sim.stats.impacts == state["stats"]["impacts"]
    finally:
        sim.close()


@pytest.mark.slow
def test_cli_load_of_a_damaged_state_is_one_line_and_status_1(saved, tmp_path, capsys):
    from dentdemo.cli import main

    folder = _broken(saved, tmp_path, "quaternion_nan")
    out = tmp_path / "out.png"
    code = main(
        [
            "render",
            "--scene",
            str(BALL_DROP),
            "--frames",
            "1",
            "--size",
            "32x32",
            "--out",
            str(out),
            "--load-state",
            str(folder),
        ]  # fmt: skip
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and "'quaternion' = [nan" in err[0], err
    assert not out.exists()


def test_demo_f9_on_a_damaged_state_is_a_panel_line_and_the_demo_runs_on(gl, saved, tmp_path):
    from dentdemo.app.controller import DemoController
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene

    folder = _broken(saved, tmp_path, "stats_hits_text")
    lib = load_materials()
    app = DemoController(gl, load_scene(BALL_DROP, lib), lib, (64, 36))
    try:
        for _ in range(5):
            app.sim.step()
        before = _fingerprint(gl, app.sim)
        assert not app.state.load(folder)
        assert "'hits' = 'lots'" in app.message and "\n" not in app.message
        assert _fingerprint(gl, app.sim) == before
        app.update(1.0 / 30.0)
        app.view.render()
        assert app.sim.world.step_index == 7  # 1/30 s of wall time = two 1/60 s steps
    finally:
        app.close()


def test_nothing_a_load_refuses_is_saved(gl, saved, tmp_path):
    """A NaN in the simulation (here its time) is refused at save, and the earlier state in the
    folder stays as it was."""
    from dentdemo.app.state import save_state

    folder = tmp_path / "kept"
    shutil.copytree(saved, folder)
    files = {p.name: p.read_bytes() for p in folder.iterdir()}
    sim = _sim(gl)
    try:
        sim.step()
        sim.world.time = math.nan
        with pytest.raises(DentdemoError) as info:
            save_state(sim, folder)
        message = str(info.value)
        assert message.startswith("--save-state: not saved") and "'time' = nan" in message
    finally:
        sim.close()
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == files
    assert [p.name for p in tmp_path.iterdir()] == ["kept"]  # no temporary folder left


def test_save_refuses_a_folder_of_other_files(gl, tmp_path):
    from dentdemo.app.state import save_state

    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "notes.txt").write_text("keep me")
    sim = _sim(gl)
    try:
        with pytest.raises(DentdemoError, match="holds 'notes.txt'"):
            save_state(sim, folder)
    finally:
        sim.close()
    assert [p.name for p in folder.iterdir()] == ["notes.txt"]


# -- kill points of a save ---------------------------------------------------------------------
def _time_of(folder: Path) -> float:
    return float(_state(folder)["world"]["time"])


def _run_save(gl, folder: Path) -> float:
    """Save a fresh run of 5 steps to `folder`; returns that run's time (s)."""
    from dentdemo.app.state import save_state

    sim = _sim(gl)
    try:
        for _ in range(5):
            sim.step()
        save_state(sim, folder)
    finally:
        sim.close()
    return 5 / 60.0


class _Killed(BaseException):
    """Stands for SIGKILL at an injected point (nothing after it runs in a real kill)."""


def _loads_with_time(gl, folder: Path) -> float:
    from dentdemo.app.state import load_state

    sim = _sim(gl)
    try:
        load_state(sim, folder)
        return sim.world.time
    finally:
        sim.close()


KILL_POINTS = [
    (True, "writing"),  # the new folder half-written
    (True, "before_swap"),  # the new folder complete, not swapped in
    (True, "removing_old"),  # exchanged, the previous folder not yet removed
    (False, "writing"),
    (False, "before_swap"),
    (False, "between_renames"),  # the previous folder aside; the new one fails to go in
    (False, "removing_old"),
]


@pytest.mark.parametrize(
    "exchange,point",
    KILL_POINTS,
    ids=[f"{'exchange' if e else 'aside'}-{p}" for e, p in KILL_POINTS],
)
@pytest.mark.slow
def test_a_save_stopped_at_any_step_leaves_the_old_state_or_the_new(
    gl, saved, tmp_path, monkeypatch, exchange, point
):
    """Each step of the save made to fail (an exception standing for a kill or Ctrl-C there):
    the folder under the final name always loads, as the previous state up to the swap and as
    the new one after it."""
    from dentdemo import outputs

    folder = tmp_path / "state"
    shutil.copytree(saved, folder)
    old_time = _time_of(folder)
    real_exchange, real_rename, real_rmtree = outputs._exchange, Path.rename, shutil.rmtree
    real_write = Path.write_bytes
    writes: list[Path] = []
    stopped: list[Path] = []

    def write_bytes(self: Path, data: bytes) -> int:
        writes.append(self)
        if point == "writing" and len(writes) == 2:
            raise _Killed
        return real_write(self, data)

    def swap(a: Path, b: Path) -> bool:
        if point == "before_swap":
            raise _Killed
        return real_exchange(a, b) if exchange else False

    def rename(self: Path, target: Path) -> Path:
        if point == "between_renames" and str(target) == str(folder) and not stopped:
            stopped.append(self)  # once: putting the previous folder back must work
            raise _Killed
        return real_rename(self, target)

    def rmtree(path: Path, *args: object, **kwargs: object) -> None:
        if point == "removing_old" and str(path) != str(folder):
            raise _Killed
        real_rmtree(path, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(Path, "write_bytes", write_bytes)
    monkeypatch.setattr(outputs, "_exchange", swap)
    monkeypatch.setattr(Path, "rename", rename)
    monkeypatch.setattr(outputs.shutil, "rmtree", rmtree)
    with pytest.raises(_Killed):
        _run_save(gl, folder)
    monkeypatch.undo()
    time = _loads_with_time(gl, folder)
    if point == "removing_old":
        assert time == pytest.approx(5 / 60.0, rel=1e-9) and time != old_time
    else:
        assert time == old_time


KILL_SCRIPT = """
import os, signal, sys
from pathlib import Path
from dentdemo import outputs
outputs._exchange = lambda a, b: False  # the path without an atomic exchange
real = Path.rename
def rename(self, target):
    result = real(self, target)
    if self.name == "state":  # the previous folder is aside, the new one not yet in
        os.kill(os.getpid(), signal.SIGKILL)
    return result
Path.rename = rename
outputs.write_folder(Path(sys.argv[1]), {"state.json": b"{}", "a.npy": b"new"})
"""


@pytest.mark.slow
def test_sigkill_between_the_renames_is_named_at_load(gl, saved, tmp_path):
    """A real SIGKILL with the previous folder renamed aside and the new one not yet in: the
    load names the leftover that holds the previous state."""
    folder = tmp_path / "state"
    shutil.copytree(saved, folder)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
    done = subprocess.run(
        [sys.executable, "-c", KILL_SCRIPT, str(folder)], env=env, timeout=60, capture_output=True
    )
    assert done.returncode == -signal.SIGKILL, done.stderr
    assert not folder.exists()
    old = [p for p in tmp_path.iterdir() if p.name.endswith(".old")]
    assert (
        len(old) == 1
        and (old[0] / "state.json").read_bytes() == (saved / "state.json").read_bytes()
    )
    from dentdemo.app.state import load_state

    sim = _sim(gl)
    try:
        with pytest.raises(DentdemoError) as info:
            load_state(sim, folder)
    finally:
        sim.close()
    assert old[0].name in str(info.value) and "killed" in str(info.value)
    old[0].rename(folder)  # the fix the line gives
    assert _loads_with_time(gl, folder) == _time_of(saved)


@pytest.mark.slow
def test_a_save_killed_before_any_of_its_file_operations_leaves_a_loadable_state(
    gl, saved, tmp_path, monkeypatch
):
    """The save stopped before its 1st, 2nd, ... rename, replace, exchange or removal, until one
    run completes: after every stop the folder loads, as the previous state or the new one."""
    import os as os_module

    from dentdemo import outputs
    from dentdemo.app.state import load_state, save_state

    saver, loader = _sim(gl), _sim(gl)
    try:
        for _ in range(60):  # 1 s: dented maps, unlike the saved state's (its carves queued)
            saver.step()
        assert saver.stats.hits > 0
        new_time = saver.world.time
        old_time = _time_of(saved)
        for k in range(1, 100):
            folder = tmp_path / f"k{k}"
            shutil.copytree(saved, folder)
            ops = {"n": 0, "k": k}

            def stop_at_k(real, ops=ops):  # noqa: ANN001, ANN202
                def op(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
                    ops["n"] += 1
                    if ops["n"] == ops["k"]:
                        raise _Killed
                    return real(*args, **kwargs)

                return op

            with monkeypatch.context() as m:
                for name in ("rename", "replace"):
                    m.setattr(os_module, name, stop_at_k(getattr(os_module, name)))
                m.setattr(shutil, "rmtree", stop_at_k(shutil.rmtree))
                if hasattr(outputs, "_exchange"):
                    m.setattr(outputs, "_exchange", stop_at_k(outputs._exchange))
                try:
                    save_state(saver, folder)
                    finished = True
                except _Killed:
                    finished = False
            load_state(loader, folder)
            assert loader.world.time in (old_time, new_time), k
            if finished:
                assert loader.world.time == new_time
                break
        assert finished and k >= 2
    finally:
        saver.close()
        loader.close()


def _map_replaced(saved: Path, tmp_path: Path, how: str) -> Path:
    """The saved state with steel_plate.npy replaced as `how` says, state.json's hash of it
    updated (so that only the map's content is at fault)."""
    import hashlib

    folder = tmp_path / how
    shutil.copytree(saved, folder)
    target = folder / "steel_plate.npy"
    height = np.load(target)
    if how == "five_metres_deep":  # a 2 cm plate of max_dent_depth 0.01
        height[10, 10] = -5.0
    elif how == "far_above":
        height[3, 4] = 3e30
    if how in ("five_metres_deep", "far_above"):
        np.save(target, height)
    elif how == "trailing_junk":
        with open(target, "ab") as handle:
            handle.write(b"junk" * 100)
    elif how == "huge_trailing_junk":  # 500 MB, sparse: nothing is read of it
        os.truncate(target, 500 << 20)
    state = _state(folder)
    state["maps"]["steel_plate"]["sha256"] = hashlib.sha256(target.read_bytes()).hexdigest()
    (folder / "state.json").write_text(json.dumps(state))
    return folder


@pytest.mark.parametrize(
    "how,fragment",
    [
        ("five_metres_deep", "heights from -5 to 0 m, outside [-0.01, 0] m"),
        ("far_above", "to 3e+30 m, outside [-0.01, 0] m"),
        ("trailing_junk", "400 bytes after the map's data"),
        ("huge_trailing_junk", "524288000 bytes, more than the"),
    ],
)
def test_a_map_holding_what_no_run_makes_is_refused(gl, saved, tmp_path, how, fragment):
    """Issue 46 item 6: heights of -5 m in a plate whose max_dent_depth is 0.01, or +3e30 m,
    loaded (and were saved again), and a map with trailing junk loaded. Each is one line naming
    the map, nothing changed; and a save refuses such heights too."""
    from dentdemo.app.state import load_state, save_state

    folder = _map_replaced(saved, tmp_path, how)
    sim = _sim(gl)
    try:
        before = _fingerprint(gl, sim)
        with pytest.raises(DentdemoError) as info:
            load_state(sim, folder)
        message = str(info.value)
        assert message.startswith(f"{folder / 'steel_plate.npy'}: ") and fragment in message
        assert "\n" not in message and _fingerprint(gl, sim) == before
        if how == "five_metres_deep":
            height = np.zeros(sim.bodies["steel_plate"].maps.size[::-1], np.float32)
            height[10, 10] = -5.0
            sim.bodies["steel_plate"].maps.height.write(height.tobytes())
            with pytest.raises(DentdemoError, match="not saved, a load would refuse it"):
                save_state(sim, tmp_path / "again")
            assert not (tmp_path / "again").exists()
    finally:
        sim.close()
