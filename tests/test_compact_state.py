"""Compact saved states (app/compact.py): a checkpoint and the hit log since it instead of every
map. The oracle is the run that never stopped: a run saved compactly, loaded in a new
simulation and continued ends with its maps, height and normal, bit for bit."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from cli_helpers import dentdemo
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
BALL_DROP = ROOT / "assets" / "scenes" / "ball_drop.toml"


def _sim(gl):
    from dentdemo.app.simulation import Simulation

    lib = load_materials()
    return Simulation(gl, load_scene(BALL_DROP, lib), lib)


def _maps(sim) -> dict[str, tuple[bytes, bytes]]:
    return {
        body_id: (sim.gl.read(body.maps.height).tobytes(), sim.gl.read(body.maps.normal).tobytes())
        for body_id, body in sorted(sim.bodies.items())
    }


def _steps(sim, n: int) -> None:
    for _ in range(n):
        sim.step()


def _busy_run(sim, saves_at: list[int], save) -> None:  # noqa: ANN001 - save(sim, n)
    """ball_drop with balls added while running and an undo; `save(sim, i)` at each frame of
    `saves_at` (counted from 0, after frame 56)."""
    for frame in range(220):
        if frame == 40:
            sim.drop_ball((0.05, 0.3, 0.02), velocity=(0.0, -4.0, 0.0), radius=0.03)
        if frame == 50:  # added, never dented before the save at 90, dented after it
            sim.drop_ball((-0.2, 0.6, 0.3), velocity=(0.0, -1.0, 0.0), radius=0.02)
        if frame == 56:  # before the saves: the undo history is not saved
            sim.undo()
        if frame in saves_at:
            save(sim, saves_at.index(frame))
        sim.step()
    sim.apply_queued()


@pytest.mark.parametrize(
    ("every", "second"),
    [(1000, 90), (4, 90), (20, 80)],
    ids=["log only", "a new checkpoint", "checkpoint and log"],
)
@pytest.mark.slow
def test_a_compact_save_resumes_bit_for_bit(gl, tmp_path, every, second):
    from dentdemo.app.state import enable_compact_saves, load_state, save_state

    straight = _sim(gl)
    enable_compact_saves(straight, every)
    saved = [tmp_path / f"s{i}" for i in range(2)]
    _busy_run(straight, [60, second], lambda sim, i: save_state(sim, saved[i]))
    want = _maps(straight)
    straight.close()
    payload = json.loads((saved[1] / "state.json").read_text())
    assert payload["maps"] == {}
    npy = sorted(p.name for p in saved[1].iterdir() if p.suffix == ".npy")
    if every == 1000:  # the log since the scene as loaded
        assert payload["checkpoint"] is None and payload["hit_log"]["hits"] > 0
        assert npy == []
    else:  # the checkpoint's maps, as its state.json lists them
        checkpoint = json.loads((saved[1] / "checkpoint.json").read_text())
        listed = [entry["file"] for entry in checkpoint["maps"].values()]
        listed += [entry["file"] for entry in payload["checkpoint"]["normals"].values()]
        assert npy == sorted(listed) and len(listed) > 1
        # 21 hits by frame 60 (a checkpoint there), 13 more by frame 80 (fewer than 20: a log
        # since that checkpoint), 1 more by 90 (more than 4: a new checkpoint)
        assert (payload["hit_log"]["hits"] > 0) == (second == 80)
    resumed = _sim(gl)
    enable_compact_saves(resumed, every)
    load_state(resumed, saved[1])
    _steps(resumed, 220 - second)  # the save came before that frame's step
    resumed.apply_queued()
    got = _maps(resumed)
    resumed.close()
    assert got.keys() == want.keys()
    assert [k for k in want if want[k] != got[k]] == []


@pytest.mark.slow
def test_ball_drop_after_600_frames_saves_ten_times_smaller(gl, tmp_path):
    """The issue's measure: the compact folder against the full one, and both load to the same
    heights (the compact one to the same normals as well: they are the carve's, not rebuilt)."""
    from dentdemo.app.state import enable_compact_saves, load_state, save_state

    sizes = {}
    for mode in ("full", "compact"):
        sim = _sim(gl)
        if mode == "compact":
            enable_compact_saves(sim)
        _steps(sim, 600)
        save_state(sim, tmp_path / mode)
        sim.close()
        sizes[mode] = sum(p.stat().st_size for p in (tmp_path / mode).iterdir())
    assert sizes["compact"] * 10 <= sizes["full"], sizes
    loaded = {}
    for mode in ("full", "compact"):
        sim = _sim(gl)
        load_state(sim, tmp_path / mode)
        loaded[mode] = {k: v[0] for k, v in _maps(sim).items()}
        sim.close()
    assert loaded["full"] == loaded["compact"]
    assert any(np.frombuffer(v, np.float32).min() < 0 for v in loaded["compact"].values())


@pytest.mark.slow
def test_a_full_state_loaded_with_compact_saves_on_is_the_checkpoint(gl, tmp_path):
    from dentdemo.app.state import enable_compact_saves, load_state, save_state

    sim = _sim(gl)
    _steps(sim, 120)
    save_state(sim, tmp_path / "full")
    _steps(sim, 100)
    want = _maps(sim)
    sim.close()
    other = _sim(gl)
    enable_compact_saves(other)
    load_state(other, tmp_path / "full")
    _steps(other, 40)
    save_state(other, tmp_path / "compact")
    other.close()
    assert (tmp_path / "compact" / "checkpoint.json").is_file()
    last = _sim(gl)
    load_state(last, tmp_path / "compact")
    _steps(last, 60)
    got = _maps(last)
    last.close()
    # heights as the run that never stopped; normals as it too, but for the full load's
    # rebuilt normals (a full state keeps heights only)
    assert {k: v[0] for k, v in got.items()} == {k: v[0] for k, v in want.items()}


def _compact_folder(gl, tmp_path: Path) -> Path:
    from dentdemo.app.state import enable_compact_saves, save_state

    sim = _sim(gl)
    enable_compact_saves(sim)
    _steps(sim, 150)
    save_state(sim, tmp_path / "good")
    sim.close()
    return tmp_path / "good"


def _rehash(folder: Path) -> None:
    import hashlib

    state = json.loads((folder / "state.json").read_text())
    data = (folder / "hits.ddhl").read_bytes()
    state["hit_log"]["sha256"] = hashlib.sha256(data).hexdigest()
    (folder / "state.json").write_text(json.dumps(state))


BROKEN = {
    "log changed": (lambda f: (f / "hits.ddhl").write_bytes(
        b"x" + (f / "hits.ddhl").read_bytes()[1:]), "sha256"),
    "log cut": (lambda f: ((f / "hits.ddhl").write_bytes((f / "hits.ddhl").read_bytes()[:-7]),
                           _rehash(f)), "hits.ddhl: record at offset"),
    "log missing": (lambda f: (f / "hits.ddhl").unlink(), "hits.ddhl: missing"),
    "maps listed": (lambda f: (f / "state.json").write_text((f / "state.json").read_text()
                    .replace('"maps": {}', '"maps": {"oak_plate": {}}')), "lists no maps"),
    "hit count": (lambda f: (f / "state.json").write_text(
        json.dumps({**json.loads((f / "state.json").read_text()),
                    "hit_log": {**json.loads((f / "state.json").read_text())["hit_log"],
                                "hits": 3}})), "'hits'"),
}  # fmt: skip


@pytest.mark.parametrize("how", sorted(BROKEN))
@pytest.mark.slow
def test_a_bad_compact_state_is_one_line_and_changes_nothing(gl, tmp_path, how):
    from dentdemo.app.state import load_state
    from dentdemo.errors import DentdemoError

    good = _compact_folder(gl, tmp_path)
    bad = tmp_path / "bad"
    shutil.copytree(good, bad)
    change, fragment = BROKEN[how]
    change(bad)
    sim = _sim(gl)
    _steps(sim, 30)
    before = _maps(sim)
    with pytest.raises(DentdemoError) as caught:
        load_state(sim, bad)
    message = str(caught.value)
    assert "\n" not in message and fragment in message, message
    assert _maps(sim) == before
    sim.close()


@pytest.mark.slow
def test_compact_saves_replace_each_other_in_one_folder(gl, tmp_path):
    """The demo's F5 saves again and again to one folder, with a checkpoint made between."""
    from dentdemo.app.state import enable_compact_saves, load_state, save_state

    sim = _sim(gl)
    enable_compact_saves(sim, 20)
    for _ in range(3):
        _steps(sim, 40)
        save_state(sim, tmp_path / "S")
    sim.apply_queued()
    want = _maps(sim)
    sim.close()
    other = _sim(gl)
    load_state(other, tmp_path / "S")
    other.apply_queued()
    assert _maps(other) == want
    other.close()


@pytest.mark.slow
def test_compact_state_needs_save_state(tmp_path):
    result = dentdemo("render", "--frames", 1, "--out", tmp_path / "r.png", "--compact-state")
    assert result.returncode != 0 and "--compact-state" in result.stderr
    assert not (tmp_path / "r.png").exists()


@pytest.mark.slow
def test_render_saves_and_loads_a_compact_state(tmp_path):
    """By the commands: render --save-state --compact-state, then --load-state continues it to
    the maps a straight render of all the frames writes, byte for byte."""
    run = dentdemo("render", "--frames", 90, "--size", "64x36", "--out", tmp_path / "a.png",
                   "--save-state", tmp_path / "S", "--compact-state")  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert not list((tmp_path / "S").glob("*.npy"))
    go = dentdemo("render", "--frames", 60, "--size", "64x36", "--out", tmp_path / "b.png",
                  "--load-state", tmp_path / "S", "--maps-dir", tmp_path / "B")  # fmt: skip
    assert go.returncode == 0, go.stderr
    straight = dentdemo("render", "--frames", 150, "--size", "64x36", "--out", tmp_path / "c.png",
                        "--maps-dir", tmp_path / "C")  # fmt: skip
    assert straight.returncode == 0, straight.stderr
    names = sorted(p.name for p in (tmp_path / "C").iterdir())
    assert names == sorted(p.name for p in (tmp_path / "B").iterdir())
    for name in names:
        assert (tmp_path / "B" / name).read_bytes() == (tmp_path / "C" / name).read_bytes(), name
