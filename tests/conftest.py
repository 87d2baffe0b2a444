"""Shared fixtures: one headless GL context per session, reset and checked around every GL test."""

from __future__ import annotations

import os
import select
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# llvmpipe draws in the thread that calls GL, with no rasterising threads (set before any GL
# context exists; the command-line processes the tests start inherit it), unless the caller set
# LP_NUM_THREADS. llvmpipe (Mesa 22.3 here) reads a fence's count without its lock when it looks
# for a scene to reuse, and may free the fence while a rasterising thread still unlocks the
# fence's mutex: about one whole-suite run in sixteen died in malloc on a chunk of a fence's
# size whose word at the mutex's offset had been zeroed (docs/performance.md, "The test suite").
# Without those threads a fence is signalled before anyone looks, and under pytest-xdist (a
# worker a core) the suite takes as long.
os.environ.setdefault("LP_NUM_THREADS", "0")


def pytest_collection_modifyitems(items):
    """A test that opens a window (it uses the `xvfb` display) is marked `window`."""
    for item in items:
        if "xvfb" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.window)


@pytest.fixture(scope="session")
def gl_session():
    from dentdemo.gl.context import create_headless

    gl = create_headless(os.environ.get("DENTDEMO_GL_BACKEND", "egl"))
    yield gl
    gl.release()


@pytest.fixture
def gl(gl_session):
    """The session context with default state; asserts no GL error before and after the test."""
    ctx = gl_session.ctx
    gl_session.make_current()  # tests may have made and released contexts of their own
    assert ctx.error == "GL_NO_ERROR", "a GL error was pending before the test"
    _reset_state(ctx)
    yield gl_session
    err = ctx.error
    _reset_state(ctx)
    assert err == "GL_NO_ERROR", f"the test left a GL error: {err}"


@pytest.fixture
def carver(gl):
    """A carver on the session context, released after the test."""
    from dentdemo.carve.carver import Carver

    c = Carver(gl)
    yield c
    c.release()


@pytest.fixture
def bodies(gl):
    """surface_helpers.Bodies on the session context: every body released after the test."""
    from surface_helpers import Bodies

    b = Bodies(gl)
    yield b
    b.release()


@pytest.fixture
def ball_drop_app(gl):
    """The demo's controller on ball_drop, 64 x 36 pixels, closed after the test."""
    from dentdemo.app.controller import DemoController
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene

    lib = load_materials()
    controller = DemoController(
        gl, load_scene(ROOT / "assets/scenes/ball_drop.toml", lib), lib, (64, 36)
    )
    yield controller
    controller.close()


@pytest.fixture(autouse=True)
def release_presses():
    """The press fixture's cleanup: every press a test made through carve_helpers.setup is
    released after the test, whether it passed or failed."""
    yield
    import carve_helpers

    carve_helpers.release_all()


def _reset_state(ctx) -> None:
    import moderngl

    ctx.screen.use() if ctx.screen is not None else None
    ctx.disable(
        moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND | moderngl.PROGRAM_POINT_SIZE
    )
    ctx.depth_func = "<"
    ctx.blend_equation = moderngl.FUNC_ADD
    ctx.blend_func = moderngl.DEFAULT_BLENDING
    ctx.scissor = None
    ctx.wireframe = False
    ctx.front_face = "ccw"
    ctx.cull_face = "back"
    ctx.point_size = 1.0
    if ctx.fbo is not None:
        ctx.viewport = (0, 0, *ctx.fbo.size)


@pytest.fixture
def tmp_toml(tmp_path):
    def write(text: str, name: str = "user.toml") -> Path:
        path = tmp_path / name
        path.write_text(text)
        return path

    return write


def _xvfb_display():
    """Xvfb on a display number of its own: parallel workers and other checkouts' runs each get
    another (a taken number's lock file makes Xvfb exit, and the next is tried). Never :0, where
    Xlib falls back when DISPLAY names no server (tests/bad_input_cases.py's bad display). The
    number comes back through `-displayfd` once the server accepts clients."""
    if shutil.which("Xvfb") is None:
        return None
    first = 100 + os.getpid() % 800
    for number in range(first, first + 40):
        started = _xvfb(number)
        if started is not None:
            return started
    return None


def _xvfb(number: int):
    read, write = os.pipe()
    proc = subprocess.Popen(
        ["Xvfb", f":{number}", "-displayfd", str(write), "-screen", "0", "1280x800x24"]
        + ["-nolisten", "tcp"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        pass_fds=(write,),
    )
    os.close(write)
    with os.fdopen(read) as pipe:  # a line once ready; end of file if Xvfb exits first
        ready, _, _ = select.select([pipe], [], [], 30.0)
        line = pipe.readline().strip() if ready else ""
    if line != str(number) or proc.poll() is not None:
        proc.kill()
        proc.wait(timeout=10)
        return None
    return f":{number}", proc


@pytest.fixture(scope="session")
def xvfb():
    started = _xvfb_display()
    if started is None:
        pytest.skip("Xvfb is not installed (Debian package xvfb): window and GLX tests need it")
    display, proc = started
    yield display
    proc.terminate()
    proc.wait(timeout=10)
