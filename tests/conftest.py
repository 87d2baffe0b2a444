"""Shared fixtures: one headless GL context per session, reset and checked around every GL test."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


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


@pytest.fixture
def tmp_toml(tmp_path):
    def write(text: str, name: str = "user.toml") -> Path:
        path = tmp_path / name
        path.write_text(text)
        return path

    return write
