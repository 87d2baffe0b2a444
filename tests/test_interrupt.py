"""Ctrl-C (a real SIGINT) stops every long-running command within one second, with one line on
stderr, exit status 130, and no partial output left behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dentdemo.resources import assets_dir

BALL_DROP = assets_dir() / "scenes" / "ball_drop.toml"
#: Seconds to let a command get past its start (imports, GL, scene) into its main loop.
SETTLE_S = 4.0


def _interrupt(args: list[str], cwd: Path, wait_for_output: bool = False) -> tuple[int, str, float]:
    """Start `dentdemo ARGS`, let it work, send SIGINT; (exit status, stderr, seconds to exit)."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    env.pop("DISPLAY", None)
    proc = subprocess.Popen(
        [sys.executable, "-m", "dentdemo", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=cwd,
        env=env,
    )
    if wait_for_output:  # the first impact line: it is inside the ODE stepping loop
        assert proc.stdout is not None
        proc.stdout.readline()
    else:
        time.sleep(SETTLE_S)
    assert proc.poll() is None, "the command ended before it could be interrupted"
    sent = time.perf_counter()
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("SIGINT did not stop the command within 10 s")
    return proc.returncode, err, time.perf_counter() - sent


def _check(code: int, err: str, seconds: float) -> None:
    assert code == 130, err
    assert err.strip().splitlines() == ["dentdemo: interrupted"], err
    assert seconds < 1.0, f"took {seconds:.2f} s to stop"


def test_ctrl_c_stops_simulate_inside_the_ode_loop(tmp_path):
    code, err, seconds = _interrupt(
        ["simulate", "--scene", str(BALL_DROP), "--steps", "100000000"], tmp_path, True
    )
    _check(code, err, seconds)


@pytest.mark.slow
def test_ctrl_c_stops_render_and_leaves_no_file(tmp_path):
    out = tmp_path / "frames"
    code, err, seconds = _interrupt(
        [
            "render",
            "--frames",
            "1000000",
            "--size",
            "320x180",
            "--out",
            str(out / "x.png"),
            "--maps-dir",
            str(out / "maps"),
            "--save-state",
            str(out / "state"),
            "--video",
            str(out / "clip.mp4"),
        ],
        tmp_path,
    )
    _check(code, err, seconds)
    assert not out.exists() or list(out.rglob("*")) == []


@pytest.mark.slow
def test_ctrl_c_stops_indent_and_leaves_no_file(tmp_path):
    out = tmp_path / "press"
    code, err, seconds = _interrupt(
        [
            "indent",
            "--depth",
            "0.002",
            "--repeat",
            "10000",
            "--map-size",
            "256",
            "--out",
            str(out),
        ],
        tmp_path,
    )
    _check(code, err, seconds)
    assert not out.exists() or list(out.rglob("*")) == []


@pytest.mark.slow
def test_ctrl_c_stops_bench_and_leaves_no_file(tmp_path):
    code, err, seconds = _interrupt(
        ["bench", "--json", str(tmp_path / "b.json"), "--plot", str(tmp_path / "b.png")],
        tmp_path,
    )
    _check(code, err, seconds)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_ctrl_c_stops_the_headless_demo(tmp_path):
    code, err, seconds = _interrupt(["demo", "--exit-after", "3000"], tmp_path)
    assert code == 130 and seconds < 1.0, err
    # the demo says once that it renders headless, then that it was interrupted
    assert err.strip().splitlines()[-1] == "dentdemo: interrupted"
    assert list(tmp_path.iterdir()) == []
