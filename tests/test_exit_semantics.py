"""How a command ends when the user stops it: a Ctrl-C reports interruption or success, never
both (README, "Ctrl-C"); Esc before --exit-after, with a screenshot due, says so with a non-zero
status."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from dentdemo import interrupt
from dentdemo.cli import main
from dentdemo.resources import assets_dir

BALL_DROP = assets_dir() / "scenes" / "ball_drop.toml"
RENDER = ["render", "--scene", str(BALL_DROP), "--frames", "2", "--size", "32x32"]


def _ctrl_c_while_writing_the_png(monkeypatch) -> None:
    """A Ctrl-C (what the SIGINT handler does) arrives while the last frame's PNG is written."""
    from dentdemo.app import loop

    real = loop.write_png

    def write_png(path: Path, pixels):  # noqa: ANN001, ANN202
        interrupt._on_sigint(signal.SIGINT, None)
        return real(path, pixels)

    monkeypatch.setattr(loop, "write_png", write_png)


@pytest.mark.slow
def test_ctrl_c_during_the_last_write_reports_success_alone(tmp_path, monkeypatch, capsys):
    _ctrl_c_while_writing_the_png(monkeypatch)
    out = tmp_path / "o.png"
    code = main([*RENDER, "--out", str(out)])
    captured = capsys.readouterr()
    assert (code, captured.out, captured.err) == (0, f"wrote {out}\n", "")
    assert out.stat().st_size > 0


@pytest.mark.slow
def test_ctrl_c_before_a_later_output_reports_interruption_alone(tmp_path, monkeypatch, capsys):
    """The PNG is written when the Ctrl-C comes; the maps are not begun: the command says it was
    interrupted (130) and reports no output."""
    _ctrl_c_while_writing_the_png(monkeypatch)
    out, maps = tmp_path / "o.png", tmp_path / "maps"
    code = main([*RENDER, "--out", str(out), "--maps-dir", str(maps)])
    captured = capsys.readouterr()
    assert (code, captured.out, captured.err) == (130, "", "dentdemo: interrupted\n")
    assert not maps.exists()


_ESC = """
import sys
from dentdemo.app import window
from dentdemo.cli import main
real = window.DemoWindow.open
calls = []
def open_(self):
    calls.append(1)
    return real(self) and len(calls) <= 3  # Esc after three frames
window.DemoWindow.open = open_
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.slow
def test_esc_before_exit_after_with_a_screenshot_is_one_line_and_status_1(xvfb, tmp_path):
    shot = tmp_path / "shot.png"
    env = {**os.environ, "DISPLAY": xvfb}
    args = ["demo", "--scene", str(BALL_DROP), "--size", "320x180", "--quality", "low"]
    result = subprocess.run(
        [sys.executable, "-c", _ESC, *args, "--screenshot", str(shot), "--exit-after", "2"],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 1 and len(lines) == 1, result.stderr
    assert lines[0].startswith("--screenshot: the window was closed at t = 0.05 s")  # 3 x 1/60
    assert f"not written: --screenshot {shot}" in lines[0]
    assert not shot.exists()


@pytest.mark.slow
def test_a_run_that_reaches_exit_after_still_exits_0(xvfb, tmp_path):
    """The same window, not closed early: the screenshot is written and the status is 0."""
    shot = tmp_path / "shot.png"
    env = {**os.environ, "DISPLAY": xvfb}
    args = ["demo", "--scene", str(BALL_DROP), "--size", "320x180", "--quality", "low"]
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "dentdemo",
            *args,
            "--screenshot",
            str(shot),
            "--exit-after",
            "0.05",  # three 1/60 s frames
        ],  # fmt: skip
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert shot.stat().st_size > 0
