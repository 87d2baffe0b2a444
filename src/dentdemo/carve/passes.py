"""The carve's render passes as small objects: a program, the GL state it runs under (declared,
not set by hand at each call site) and the names of the textures it samples."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import moderngl

from dentdemo.gl.shaders import set_uniform

GL_CLIP_DISTANCE0 = 0x3000
#: Clip distances texel.geom writes (camera rectangle: 4, depth slab: 2).
CLIP_DISTANCES = 6


@dataclass(frozen=True)
class PassState:
    """Fixed-function state of one pass; everything not named is off."""

    depth_test: bool = False
    #: GL depth function while the depth test is on ("<" nearest wins, ">" farthest wins).
    depth_func: str = "<"
    #: Which faces to drop: "back", "front" or None (keep both).
    cull: str | None = None
    #: Blend with MIN (dents only deepen): out = min(fragment, framebuffer).
    blend_min: bool = False
    #: Texture-space draws clip to the camera's footprint with gl_ClipDistance[0..5].
    clip_distances: bool = False


@contextmanager
def applied(ctx: moderngl.Context, state: PassState) -> Iterator[None]:
    """Run under `state`, then put back moderngl's defaults (depth test, culling, blending and
    clip distances off; depth function "<"; additive blend equation)."""
    flags: int = 0  # none
    if state.depth_test:
        flags |= moderngl.DEPTH_TEST
        ctx.depth_func = state.depth_func
    if state.cull:
        flags |= moderngl.CULL_FACE
        ctx.front_face = "ccw"
        ctx.cull_face = state.cull
    if state.blend_min:
        flags |= moderngl.BLEND
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        ctx.blend_equation = (moderngl.MIN, moderngl.MIN)  # colour, alpha
    ctx.enable_only(flags)
    if state.clip_distances:
        for i in range(CLIP_DISTANCES):
            ctx.enable_direct(GL_CLIP_DISTANCE0 + i)
    try:
        yield
    finally:
        if state.clip_distances:
            for i in range(CLIP_DISTANCES):
                ctx.disable_direct(GL_CLIP_DISTANCE0 + i)
        ctx.enable_only(0)  # none
        ctx.depth_func = "<"
        ctx.cull_face = "back"
        ctx.blend_equation = (moderngl.FUNC_ADD, moderngl.FUNC_ADD)
        ctx.blend_func = (moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA)  # the default


@dataclass(frozen=True)
class Pass:
    """One pass: `run` binds `textures` to `samplers` in order, sets `uniforms`, applies the
    state and calls `draw(program)`."""

    name: str
    program: moderngl.Program
    state: PassState
    samplers: tuple[str, ...] = ()

    def run(
        self,
        ctx: moderngl.Context,
        fbo: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int],
        draw: Callable[[moderngl.Program], None],
        textures: Sequence[moderngl.Texture] = (),
        uniforms: Mapping[str, object] | None = None,
    ) -> None:
        for unit, (name, texture) in enumerate(zip(self.samplers, textures, strict=True)):
            texture.use(unit)
            set_uniform(self.program, name, unit)
        for name, value in (uniforms or {}).items():
            set_uniform(self.program, name, value)
        fbo.use()
        ctx.viewport = viewport
        with applied(ctx, self.state):
            draw(self.program)
