"""The image-based light: the procedural environment (shaders/render/environment.glsl) baked at
start into an equirectangular atlas of radiance prefiltered per roughness and a small irradiance
map. Baked once per context and sun direction (a resized window keeps it)."""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from dentdemo.gl.context import GLContext, release
from dentdemo.gl.shaders import program, set_uniform
from dentdemo.gl.state import preserved

#: Roughness rows of the prefiltered atlas (0, 0.2, ..., 1) and the texels of each row.
LEVELS = 6
LEVEL_SIZE = (256, 128)
IRRADIANCE_SIZE = (32, 16)
#: Samples per texel of the rough rows and of the irradiance map (a start-up cost only).
SPECULAR_SAMPLES = 96
IRRADIANCE_SAMPLES = 256


@dataclass
class Environment:
    radiance: moderngl.Texture  # RGBA16F, LEVELS rows of LEVEL_SIZE, linear radiance
    irradiance: moderngl.Texture  # RGBA16F, IRRADIANCE_SIZE, irradiance / pi
    sun_dir: tuple[float, float, float]

    def release(self) -> None:
        release(self.radiance, self.irradiance)


def environment(gl: GLContext, sun_dir: tuple[float, float, float]) -> Environment:
    """The baked environment for this context and sun direction (cached)."""
    key = f"environment:{tuple(round(float(x), 6) for x in sun_dir)}"
    if key not in gl.cache:
        gl.cache[key] = _bake(gl, np.asarray(sun_dir, float))
    return gl.cache[key]


def _bake(gl: GLContext, sun_dir: np.ndarray) -> Environment:
    ctx = gl.ctx
    sx, sy, sz = sun_dir / np.linalg.norm(sun_dir)
    sun = (float(sx), float(sy), float(sz))
    out = []
    for irradiance, size, rows, samples in (
        (0, LEVEL_SIZE, LEVELS, SPECULAR_SAMPLES),
        (1, IRRADIANCE_SIZE, 1, IRRADIANCE_SAMPLES),
    ):
        texture = ctx.texture((size[0], size[1] * rows), 4, dtype="f2")
        texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        texture.repeat_x, texture.repeat_y = True, False
        prog = program(
            gl.cache,
            ctx,
            "util/fullscreen.vert",
            "render/bake_environment.frag",
            defines={"IRRADIANCE": irradiance},
        )
        for name, value in (
            ("u_sun_dir", sun),
            ("u_level_size", size),
            ("u_levels", rows),
            ("u_samples", samples),
        ):
            set_uniform(prog, name, value)
        with preserved(ctx):
            fbo = ctx.framebuffer([texture])
            fbo.use()
            ctx.viewport = (0, 0, size[0], size[1] * rows)
            ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
            vao = ctx.vertex_array(prog, [])
            vao.render(moderngl.TRIANGLES, vertices=3)
            release(vao, fbo)
        out.append(texture)
    return Environment(out[0], out[1], sun)
