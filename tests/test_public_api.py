"""The public API: `help(dentdemo)` documents it, the example under examples/ carves a visible dent
in its own context, and carving and map creation leave the host's GL state as it was."""

from __future__ import annotations

import ast
import ctypes
import subprocess
import sys
from pathlib import Path

import moderngl
import numpy as np
import pytest
from PIL import Image

import dentdemo
from dentdemo.gl import state as gl_state

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "carve_in_your_context.py"


def test_help_documents_the_api(capsys):
    help(dentdemo)
    text = capsys.readouterr().out
    for name in ("DentableSurface", "Carver", "Contact", "mesh_from_triangles", "shape_mesh"):
        assert name in text
    # The summary is about one screen; each public name's own documentation follows it (pydoc
    # documents every name of __all__).
    assert len(dentdemo.__doc__.splitlines()) <= 60
    assert text.index("DESCRIPTION") < text.index("class Carver")
    for name in dentdemo.API:
        assert getattr(dentdemo, name).__doc__, name
        assert name in dir(dentdemo)


def _example(tmp_path: Path, *flags: str) -> tuple[dict, np.ndarray]:
    out = tmp_path / f"example{''.join(flags)}.png"
    done = subprocess.run(
        [sys.executable, str(EXAMPLE), "--out", str(out), *flags],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    summary = ast.literal_eval(done.stdout.strip().splitlines()[-1])  # the dict it prints
    return summary, np.asarray(Image.open(out)).astype(int)


@pytest.mark.slow
def test_example_carves_a_visible_dent_headless(tmp_path):
    dented, after = _example(tmp_path)
    plain, before = _example(tmp_path, "--no-press")
    assert dented["pressed"] and not plain["pressed"]
    # A 6 mm press of a 5 cm ball into the top of a torus tube: 6 mm deep (texel-centre sampling).
    assert dented["depth_m"] == pytest.approx(0.006, rel=0.02)
    assert plain["depth_m"] == 0.0
    changed = np.abs(after - before).max(axis=2) >= 10
    # The dent shows, and only where it is: a small patch of the 480 x 360 image.
    assert 300 < changed.sum() < 0.05 * changed.size
    rows, cols = np.nonzero(changed)
    assert np.ptp(rows) < 120 and np.ptp(cols) < 120
    # Shaded as a dent, not a bump: the light comes from +z (and +x, +y); the camera's screen
    # up is world -z. A pit's wall on its -z side faces +z, so the upper half of the dent is
    # brighter than its lower half (a bump, or a tangent frame off by a sign, the other way).
    grey = after.mean(axis=2)[rows, cols]
    middle = (rows.min() + rows.max()) / 2  # image rows run top-down
    upper, lower = grey[rows < middle].mean(), grey[rows > middle].mean()
    assert upper > lower + 10, (upper, lower)


# -- the host's GL state ---------------------------------------------------------------------------
def _raw() -> ctypes.CDLL:
    gl = ctypes.CDLL("libOpenGL.so.0")
    gl.glIsEnabled.restype = ctypes.c_ubyte
    return gl


def _ints(gl: ctypes.CDLL, pname: int, count: int = 1) -> list[int]:
    out = (ctypes.c_int * 4)()
    gl.glGetIntegerv(pname, out)
    return list(out[:count])


def _host_state(ctx: moderngl.Context) -> dict:
    """A hand-picked part of the state, read independently of dentdemo.gl.state."""
    gl = _raw()
    return {
        "blend": gl.glIsEnabled(0x0BE2),
        "depth_test": gl.glIsEnabled(0x0B71),
        "cull_face": gl.glIsEnabled(0x0B44),
        "scissor_test": gl.glIsEnabled(0x0C11),
        "clip0": gl.glIsEnabled(0x3000),
        "depth_func": _ints(gl, 0x0B74),
        "cull_mode": _ints(gl, 0x0B45),
        "front_face": _ints(gl, 0x0B46),
        "blend_src": _ints(gl, 0x80C9),
        "blend_eq": _ints(gl, 0x8009),
        "viewport": _ints(gl, 0x0BA2, 4),
        "scissor": _ints(gl, 0x0C10, 4),
        "draw_fbo": _ints(gl, 0x8CA6),
        "program": _ints(gl, 0x8B8D),
        "vao": _ints(gl, 0x85B5),
        "active_texture": _ints(gl, 0x84E0),
        "moderngl_fbo": ctx.fbo,
        "moderngl_viewport": ctx.viewport,
    }


def test_carving_and_map_creation_keep_the_host_gl_state(gl):
    ctx = gl.ctx
    # The host's frame, mid-way: its framebuffer, program, vertex array and odd state.
    fbo = ctx.framebuffer([ctx.texture((64, 48), 4)], ctx.depth_renderbuffer((64, 48)))
    fbo.use()
    ctx.viewport = (3, 5, 41, 37)
    ctx.scissor = (1, 2, 30, 20)
    ctx.enable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
    ctx.depth_func = ">="
    ctx.blend_func = moderngl.SRC_COLOR, moderngl.DST_ALPHA
    ctx.blend_equation = moderngl.MAX
    ctx.cull_face = "front"
    ctx.front_face = "cw"
    ctx.point_size = 4.0
    prog = ctx.program(
        vertex_shader="#version 330 core\nin vec2 p; void main(){gl_Position=vec4(p,0,1);}",
        fragment_shader="#version 330 core\nout vec4 c; void main(){c=vec4(1);}",
    )
    vbo = ctx.buffer(np.zeros(6, "f4").tobytes())
    vao = ctx.vertex_array(prog, [(vbo, "2f", "p")])
    textures = [ctx.texture((4, 4), 1) for _ in range(4)]
    for unit, texture in enumerate(textures):
        texture.use(unit)
    raw = _raw()
    raw.glUseProgram(prog.glo)
    raw.glBindVertexArray(vao.glo)
    raw.glActiveTexture(0x84C0 + 2)
    ctx.enable_direct(0x3000)  # GL_CLIP_DISTANCE0
    before, full = _host_state(ctx), gl_state.capture()

    plate = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Plate(0.4)), 256)
    assert _host_state(ctx) == before and gl_state.capture() == full  # map creation
    ball = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Sphere(0.05)), 64)
    ball.model = np.eye(4)
    ball.model[1, 3] = 0.05
    carver = dentdemo.Carver(ctx)
    assert carver.press(plate, ball, dentdemo.Contact((0, 0, 0), (0, -1, 0)), 0.004, 0.001)
    assert _host_state(ctx) == before and gl_state.capture() == full  # the carve
    assert float(plate.heights().min()) == pytest.approx(-0.004, abs=1e-4)
    assert _host_state(ctx) == before  # and the read-back

    ctx.disable_direct(0x3000)
    for thing in (carver, ball, plate, vao, vbo, prog, *textures):
        thing.release()
    from dentdemo.gl.context import release

    release(fbo)
