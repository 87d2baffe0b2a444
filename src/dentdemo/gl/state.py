"""The host's GL state, read from GL itself and put back: dentdemo's public entry points (carving,
map creation) run inside `preserved(ctx)`, so a host program's framebuffer, viewport, tests, blend,
culling, bindings and masks are as it left them. Reads go through the driver (glGet*, glIsEnabled)
rather than moderngl's bookkeeping, so state the host set by any means is kept."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import moderngl

from dentdemo.gl.context import parking_framebuffer
from dentdemo.gl.library import gl_library as _gl

# Capabilities a pass or a host may switch (glEnable / glDisable).
CAPABILITIES = {
    "blend": 0x0BE2,
    "cull_face": 0x0B44,
    "depth_test": 0x0B71,
    "scissor_test": 0x0C11,
    "stencil_test": 0x0B90,
    "polygon_offset_fill": 0x8037,
    "program_point_size": 0x8642,
    "rasterizer_discard": 0x8C89,
    "framebuffer_srgb": 0x8DB9,
    "multisample": 0x809D,
    **{f"clip_distance{i}": 0x3000 + i for i in range(8)},
}
# Integer state (glGetIntegerv), with how many values each holds.
INTEGERS = {
    "depth_func": (0x0B74, 1),
    "cull_face_mode": (0x0B45, 1),
    "front_face": (0x0B46, 1),
    "blend_src_rgb": (0x80C9, 1),
    "blend_dst_rgb": (0x80C8, 1),
    "blend_src_alpha": (0x80CB, 1),
    "blend_dst_alpha": (0x80CA, 1),
    "blend_equation_rgb": (0x8009, 1),
    "blend_equation_alpha": (0x883D, 1),
    "viewport": (0x0BA2, 4),
    "scissor_box": (0x0C10, 4),
    "draw_framebuffer": (0x8CA6, 1),
    "read_framebuffer": (0x8CAA, 1),
    "program": (0x8B8D, 1),
    "vertex_array": (0x85B5, 1),
    "array_buffer": (0x8894, 1),
    "active_texture": (0x84E0, 1),
    "unpack_alignment": (0x0CF5, 1),
    "pack_alignment": (0x0D05, 1),
    "polygon_mode": (0x0B40, 2),
}
BOOLEANS = {"depth_mask": (0x0B72, 1), "color_mask": (0x0C23, 4)}
FLOATS = {"point_size": (0x0B11, 1), "polygon_offset": (0x8038, 1), "polygon_units": (0x2A00, 1)}
#: Texture units whose 2D texture bindings are kept (the carve binds at most three).
TEXTURE_UNITS = 8
_TEXTURE0 = 0x84C0
_TEXTURE_BINDING_2D = 0x8069
_TEXTURE_2D = 0x0DE1
_FRONT_AND_BACK = 0x0408


@dataclass(frozen=True)
class GLState:
    """A snapshot of the state above (values as GL reports them)."""

    enabled: dict[str, bool]
    integers: dict[str, tuple[int, ...]]
    booleans: dict[str, tuple[bool, ...]]
    floats: dict[str, tuple[float, ...]]
    textures: tuple[int, ...]


def capture() -> GLState:
    """The current context's state (it must be current)."""
    gl = _gl()
    enabled = {name: bool(gl.glIsEnabled(cap)) for name, cap in CAPABILITIES.items()}

    def ints(pname: int, count: int) -> tuple[int, ...]:
        out = (ctypes.c_int * 4)()
        gl.glGetIntegerv(pname, out)
        return tuple(out[:count])

    def bools(pname: int, count: int) -> tuple[bool, ...]:
        out = (ctypes.c_ubyte * 4)()
        gl.glGetBooleanv(pname, out)
        return tuple(bool(v) for v in out[:count])

    def floats(pname: int, count: int) -> tuple[float, ...]:
        out = (ctypes.c_float * 4)()
        gl.glGetFloatv(pname, out)
        return tuple(out[:count])

    integers = {name: ints(*spec) for name, spec in INTEGERS.items()}
    active = integers["active_texture"][0]
    textures = []
    for unit in range(TEXTURE_UNITS):
        gl.glActiveTexture(_TEXTURE0 + unit)
        textures.append(ints(_TEXTURE_BINDING_2D, 1)[0])
    gl.glActiveTexture(active)
    return GLState(
        enabled,
        integers,
        {name: bools(*spec) for name, spec in BOOLEANS.items()},
        {name: floats(*spec) for name, spec in FLOATS.items()},
        tuple(textures),
    )


def restore(state: GLState) -> None:
    """Put `state` back in the current context."""
    gl = _gl()
    for name, cap in CAPABILITIES.items():
        (gl.glEnable if state.enabled[name] else gl.glDisable)(cap)
    i = state.integers
    gl.glDepthFunc(i["depth_func"][0])
    gl.glCullFace(i["cull_face_mode"][0])
    gl.glFrontFace(i["front_face"][0])
    gl.glBlendFuncSeparate(
        i["blend_src_rgb"][0],
        i["blend_dst_rgb"][0],
        i["blend_src_alpha"][0],
        i["blend_dst_alpha"][0],
    )
    gl.glBlendEquationSeparate(i["blend_equation_rgb"][0], i["blend_equation_alpha"][0])
    gl.glViewport(*i["viewport"])
    gl.glScissor(*i["scissor_box"])

    def alive(test: str, name: int) -> int:
        """`name` if it still names an object (a program the host deleted while current is
        gone once another is used), else 0."""
        return name if name and getattr(gl, test)(name) else 0

    gl.glBindFramebuffer(0x8CA9, alive("glIsFramebuffer", i["draw_framebuffer"][0]))
    gl.glBindFramebuffer(0x8CA8, alive("glIsFramebuffer", i["read_framebuffer"][0]))
    gl.glUseProgram(alive("glIsProgram", i["program"][0]))
    gl.glBindVertexArray(alive("glIsVertexArray", i["vertex_array"][0]))
    gl.glBindBuffer(0x8892, alive("glIsBuffer", i["array_buffer"][0]))  # GL_ARRAY_BUFFER
    gl.glPixelStorei(0x0CF5, i["unpack_alignment"][0])
    gl.glPixelStorei(0x0D05, i["pack_alignment"][0])
    gl.glPolygonMode(_FRONT_AND_BACK, i["polygon_mode"][0])
    for unit, texture in enumerate(state.textures):
        gl.glActiveTexture(_TEXTURE0 + unit)
        gl.glBindTexture(_TEXTURE_2D, alive("glIsTexture", texture))
    gl.glActiveTexture(i["active_texture"][0])
    gl.glDepthMask(ctypes.c_ubyte(state.booleans["depth_mask"][0]))
    gl.glColorMask(*(ctypes.c_ubyte(v) for v in state.booleans["color_mask"]))
    gl.glPointSize(ctypes.c_float(state.floats["point_size"][0]))
    gl.glPolygonOffset(
        ctypes.c_float(state.floats["polygon_offset"][0]),
        ctypes.c_float(state.floats["polygon_units"][0]),
    )


@contextmanager
def preserved(ctx: moderngl.Context) -> Iterator[None]:
    """Run the body, then give the host back its GL state and moderngl's idea of it (the bound
    framebuffer object and viewport moderngl reports)."""
    fbo = ctx.fbo
    state = capture()
    try:
        yield
    finally:
        # moderngl's record of the binding (it re-binds it whenever it makes a framebuffer):
        # the host's, or, where the host never bound one, a framebuffer that is never released.
        (fbo if fbo is not None else parking_framebuffer(ctx)).use()
        restore(state)  # GL's own binding and the rest
