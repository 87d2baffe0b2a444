"""Hot reload (issue 23, item 1): the demo's materials and scene files are watched while it runs.
Driven through the controller (no window), then once through a real window under Xvfb."""

from __future__ import annotations

import math
import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from dentdemo.app.controller import DemoController
from dentdemo.app.watch import POLL_INTERVAL
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
from scene_text import GROUND, ball, camera, plate

#: A user file overriding steel (the shipped values but restitution and density) and adding a
#: preset of its own.
USER = """# my presets: a comment that must survive
[materials.steel]
youngs_modulus_Pa = 200e9
yield_stress_Pa = 250e6
plastic_modulus_Pa = 2.0e9
density_kg_m3 = {density}
restitution = {restitution}
friction = 0.6
max_dent_depth_m = 0.01

[materials.putty]
youngs_modulus_Pa = 1e6
yield_stress_Pa = 1e4
plastic_modulus_Pa = 1e5
density_kg_m3 = 1500
restitution = 0.05
friction = 0.9
max_dent_depth_m = 0.02
"""

SCENE = "\n".join(
    [
        '[scene]\nname = "tiny"\n',
        camera("[1.0, 0.8, 1.0]"),
        GROUND,
        plate("steel", texels=256),
        ball("steel", "[{x}, 0.3, 0.0]", texels=256),
    ]
)

SECOND_BALL = """
[[body]]
id = "ball_two"
shape = "sphere"
radius = 0.03
material = "putty"
position = [-0.1, 0.5, 0.0]
"""

BALL_MASS_AT = 4.0 / 3.0 * math.pi * 0.04**3  # m^3: kg per (kg/m^3) of a 4 cm ball


def _files(tmp_path: Path) -> tuple[Path, Path]:
    user = tmp_path / "mine.toml"
    user.write_text(USER.format(density=7850, restitution=0.6))
    scene = tmp_path / "tiny.toml"
    scene.write_text(SCENE.format(x=0.0))
    return user, scene


def _app(gl, user: Path, scene_path: Path) -> DemoController:
    lib = load_materials([user])
    app = DemoController(gl, load_scene(scene_path, lib), lib, (64, 36))
    app.reload.watch([user], scene_path)
    return app


def _settle(app: DemoController, start: float, seconds: float = 1.0) -> tuple[float, list[str]]:
    """Poll once a frame (60 Hz) from `start` for `seconds`: (when the first line came, lines)."""
    t = start
    while t < start + seconds:
        lines = app.reload.poll(t)
        if lines:
            return t - start, lines
        t += 1.0 / 60.0
    return math.inf, []


def test_a_saved_materials_edit_reaches_every_body_and_new_balls_within_a_second(
    gl, tmp_path, capsys
):
    user, scene_path = _files(tmp_path)
    app = _app(gl, user, scene_path)
    try:
        for _ in range(3):
            app.sim.step()
        assert app.reload.poll(0.0) == []  # nothing changed
        user.write_text(USER.format(density=2 * 7850, restitution=0.3))
        after, lines = _settle(app, 10.0)
        # Two polls POLL_INTERVAL apart settle a change: well within a second of the save.
        assert after <= 2 * POLL_INTERVAL + 1e-9
        assert lines == [f"dentdemo: reloaded {user} (2 materials)"]
        assert lines[0] in capsys.readouterr().err.splitlines()
        assert app.message == lines[0]
        ball, plate = app.sim.bodies["ball"], app.sim.bodies["plate"]
        for body in (ball, plate):
            assert body.spec.material.restitution == 0.3
            assert body.spec.material.density == 2 * 7850
        # The physics sees the new preset: the ball's mass from the new density (by hand).
        record = app.sim.world.bodies["ball"]
        assert record.mass == pytest.approx(BALL_MASS_AT * 2 * 7850, rel=1e-12)
        assert record.spec.material.restitution == 0.3
        # A reset keeps the new values (the scene's specs were renewed too); so do new balls.
        new = app.sim.drop_ball((0.1, 0.5, 0.0), material="steel")
        assert app.sim.bodies[new].spec.material.restitution == 0.3
        assert app.sim.world.bodies[new].mass == pytest.approx(BALL_MASS_AT * 2 * 7850, rel=1e-12)
        app.reset()
        assert app.sim.bodies["ball"].spec.material.density == 2 * 7850
        app.sim.step()
    finally:
        app.close()


def test_a_reloaded_restitution_changes_the_next_bounce(gl, tmp_path):
    """The contact's bounce comes from the reloaded preset: a ball dropped after the edit comes
    back up higher with restitution 0.9 than the same drop before with 0.1 (both balls steel on
    steel: eps = min of the pair)."""
    user, scene_path = _files(tmp_path)
    user.write_text(USER.format(density=7850, restitution=0.1))
    app = _app(gl, user, scene_path)

    def rebound(x: float) -> float:
        ball = app.sim.drop_ball((x, 0.25, 0.0), material="steel")
        top, falling = 0.0, True
        for _ in range(90):
            app.sim.step()
            y, vy = app.sim.world.pose(ball)[0][1], app.sim.world.velocity(ball)[0][1]
            falling = falling and vy <= 0.0
            if not falling:
                top = max(top, y)
        app.sim.remove_body(ball)
        return top

    try:
        low = rebound(0.12)
        user.write_text(USER.format(density=7850, restitution=0.9))
        assert _settle(app, 0.0)[1]
        high = rebound(-0.12)
        # Drop from 0.25 m to the plate top (0.02) + radius: h = 0.19 m; a bounce reaches
        # eps^2 h above the contact height: 0.0019 m at 0.1, 0.154 m at 0.9.
        assert low < 0.06 + 0.01 and high > 0.06 + 0.12
    finally:
        app.close()


def test_an_invalid_edit_is_the_start_up_error_and_keeps_the_last_good_values(gl, tmp_path, capsys):
    user, scene_path = _files(tmp_path)
    app = _app(gl, user, scene_path)
    try:
        user.write_text(USER.format(density=7850, restitution=1.5))
        _, lines = _settle(app, 0.0)
        expected = f"{user}: [materials.steel] key 'restitution' = 1.5: must be < 1"
        assert len(lines) == 1 and lines[0].startswith(expected + " (range [0, 1)")
        expected = lines[0]
        start_up = subprocess.run(
            [sys.executable, "-m", "dentdemo", "materials", "--materials", str(user)],
            capture_output=True,
            text=True,
        )
        assert start_up.returncode == 1 and start_up.stderr.strip() == expected
        assert capsys.readouterr().err.splitlines() == [expected]
        assert app.message == expected
        assert app.sim.bodies["ball"].spec.material.restitution == 0.6
        for _ in range(5):
            app.sim.step()  # the demo keeps running
        # Mended: the next save is applied.
        user.write_text(USER.format(density=7850, restitution=0.5))
        _, lines = _settle(app, 5.0)
        assert lines == [f"dentdemo: reloaded {user} (2 materials)"]
        assert app.sim.bodies["ball"].spec.material.restitution == 0.5
    finally:
        app.close()


def test_a_density_ode_cannot_hold_is_refused_on_reload_and_the_run_goes_on(gl, tmp_path):
    """Issue 46 item 1: 1e200 kg/m^3 passed the validator, printed "reloaded" and then aborted
    the process inside ODE (dNormalize4) with the session's damage. Now it is the start-up
    error with the key's range, and the last good density stays in use."""
    user, scene_path = _files(tmp_path)
    app = _app(gl, user, scene_path)
    try:
        user.write_text(USER.format(density=1e200, restitution=0.6))
        _, lines = _settle(app, 0.0)
        assert len(lines) == 1, lines
        assert "key 'density_kg_m3' = 1e+200: must be <= 100000" in lines[0]
        assert "range [0.1, 100000] kg/m^3" in lines[0]
        assert app.sim.bodies["ball"].spec.material.density == 7850
        for _ in range(60):
            app.sim.step()
        assert math.isfinite(app.sim.world.snapshot().bodies["ball"][0][1])
    finally:
        app.close()


def test_emptying_a_file_says_which_overrides_it_no_longer_sets(gl, tmp_path):
    """Issue 46 item 8: an emptied materials file reported "reloaded (0 materials)" and
    silently dropped its overrides. The line now names them; steel is the built-in one again."""
    user, scene_path = _files(tmp_path)
    user.write_text(USER.format(density=8000, restitution=0.6))
    app = _app(gl, user, scene_path)
    try:
        assert app.sim.bodies["ball"].spec.material.density == 8000
        user.write_text("")
        _, lines = _settle(app, 0.0)
        assert lines == [
            f"dentdemo: reloaded {user} (0 materials); it no longer sets steel, putty: "
            "built-in or earlier files' values, where any"
        ]
        assert app.sim.bodies["ball"].spec.material.density == 7850  # assets/materials.toml
    finally:
        app.close()


def test_two_files_saved_together_are_each_reported(gl, tmp_path):
    user, scene_path = _files(tmp_path)
    second = tmp_path / "more.toml"
    second.write_text(USER.split("[materials.putty]")[1].join(["[materials.putty]", ""]))
    lib = load_materials([user, second])
    app = DemoController(gl, load_scene(scene_path, lib), lib, (64, 36))
    app.reload.watch([user, second], scene_path)
    try:
        user.write_text(USER.format(density=7850, restitution=0.4))
        second.write_text(second.read_text().replace("restitution = 0.05", "restitution = 0.07"))
        _, lines = _settle(app, 0.0)
        assert lines == [
            f"dentdemo: reloaded {user} (2 materials)",
            f"dentdemo: reloaded {second} (1 materials)",
        ]
        assert app.sim.materials.materials["putty"].restitution == 0.07
        assert app.sim.bodies["ball"].spec.material.restitution == 0.4
    finally:
        app.close()


def test_a_preset_a_body_uses_cannot_vanish(gl, tmp_path):
    user, scene_path = _files(tmp_path)
    app = _app(gl, user, scene_path)
    try:
        ball = app.sim.drop_ball((0.1, 0.4, 0.0), material="putty")
        user.write_text(USER.format(density=7850, restitution=0.2).split("[materials.putty]")[0])
        _, lines = _settle(app, 0.0)
        assert len(lines) == 1
        assert lines[0].startswith(f"{user}: body '{ball}': unknown material 'putty'")
        # Nothing changed: not even the steel that the same save edited.
        assert app.sim.bodies["ball"].spec.material.restitution == 0.6
        assert "putty" in app.sim.materials.materials
    finally:
        app.close()


def test_a_scene_edit_offers_a_reset_to_the_new_scene(gl, tmp_path, capsys):
    user, scene_path = _files(tmp_path)
    app = _app(gl, user, scene_path)
    try:
        scene_path.write_text(SCENE.format(x=0.1) + SECOND_BALL)
        _, lines = _settle(app, 0.0)
        assert lines == [f"dentdemo: {scene_path} changed (4 bodies): reset (R) to load it"]
        assert app.reload.scene_changed
        assert set(app.sim.bodies) == {"ground", "plate", "ball"}  # offered, not forced
        assert app.sim.world.pose("ball")[0][0] == 0.0
        app.reset()
        assert set(app.sim.bodies) == {"ground", "plate", "ball", "ball_two"}
        assert app.sim.world.pose("ball")[0][0] == pytest.approx(0.1, abs=1e-12)
        assert not app.reload.scene_changed
        # An invalid scene edit: the start-up error, and the scene running stays.
        scene_path.write_text(SCENE.format(x=0.0).replace("radius = 0.04", "radius = -1"))
        _, lines = _settle(app, 5.0)
        assert lines == [f"{scene_path}: [body.ball] key 'radius' = -1: must be >= 0.001"]
        assert not app.reload.scene_changed
        app.reset()
        assert "ball_two" in app.sim.bodies
    finally:
        app.close()


def test_the_watcher_reads_a_save_once_whole(tmp_path):
    """An editor's save in two writes: the half-written file seen by one poll is not reported;
    the whole file, seen by two, is, once."""
    from dentdemo.app.watch import FileWatcher

    path = tmp_path / "f.toml"
    path.write_text("a = 1\n")
    watcher = FileWatcher((path,))
    path.write_text("a = ")
    assert watcher.poll(0.0) == []
    path.write_text("a = 2\n")
    assert watcher.poll(0.2) == []  # changed again since the last poll: not settled
    assert watcher.poll(0.3) == []  # too soon after the last poll
    assert watcher.poll(0.4) == [path]
    assert watcher.poll(0.6) == []
    path.unlink()
    watcher.poll(1.0)
    assert watcher.poll(2.0) == [path]  # gone: reported, and the reader names the file


def _unblock(fifo: Path, done: threading.Event) -> None:
    """Until `done`, end any read blocked on `fifo` twice a second (a writer that opens it and
    closes at once: the reader sees the end of the file)."""
    while not done.wait(0.5):
        try:
            os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        except OSError:  # no reader: nothing is blocked
            pass


WINDOW_SCENE_SECONDS = 12.0  # simulated, one dt a frame: 3.5 s of wall time here (llvmpipe)


@pytest.mark.slow
def test_real_window_reloads_and_reports_a_bad_edit(xvfb, tmp_path):
    user, scene_path = _files(tmp_path)
    env = {**os.environ, "DISPLAY": xvfb}
    command = [
        sys.executable,
        "-m",
        "dentdemo",
        "demo",
        "--materials",
        str(user),
        "--scene",
        str(scene_path),
        "--size",
        "320x180",
        "--quality",
        "low",
        "--exit-after",
        str(WINDOW_SCENE_SECONDS),
    ]
    proc = subprocess.Popen(command, env=env, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    assert proc.stderr is not None
    seen: list[str] = []
    done = threading.Event()

    lines: queue.Queue[str] = queue.Queue()  # stderr's lines, read by a thread of their own
    threading.Thread(target=lambda: [lines.put(x) for x in proc.stderr], daemon=True).start()

    def wait_for(prefix: str) -> str:
        """The next line starting `prefix`, within 60 s (a frozen window sends none)."""
        deadline = time.monotonic() + 60
        while (left := deadline - time.monotonic()) > 0:
            try:
                line = lines.get(timeout=left)
            except queue.Empty:
                break
            seen.append(line.rstrip("\n"))
            if line.startswith(prefix):
                return line.rstrip("\n")
        proc.kill()
        raise AssertionError(f"no line starting {prefix!r}; stderr so far: {seen}")

    try:
        wait_for("dentdemo: watching")
        user.write_text(USER.format(density=7850, restitution=0.3))
        assert wait_for("dentdemo: reloaded") == f"dentdemo: reloaded {user} (2 materials)"
        # Issue 46 item 1: this density printed "reloaded", then aborted the demo inside ODE.
        user.write_text(USER.format(density=1e200, restitution=0.3))
        assert wait_for(str(user)).startswith(
            f"{user}: [materials.steel] key 'density_kg_m3' = 1e+200: must be <= 100000 "
            "(range [0.1, 100000] kg/m^3"
        )
        # Issue 46 item 5: a FIFO in its place froze the window (the watcher blocked reading
        # it). A writer opening it twice a second ends any blocked read, so that a reader
        # that opens it fails here rather than hanging.
        user.unlink()
        os.mkfifo(user)
        unblocking = threading.Thread(target=_unblock, args=(user, done), daemon=True)
        unblocking.start()
        assert wait_for(str(user)) == f"{user}: cannot read: a FIFO, not a regular file"
        assert proc.wait(timeout=120) == 0, seen
    finally:
        done.set()
        if proc.poll() is None:
            proc.kill()
            proc.wait()
