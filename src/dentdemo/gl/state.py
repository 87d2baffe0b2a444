"""The host's GL state, read from GL itself and put back: dentdemo's public entry points (carving,
map creation) run inside `preserved(ctx)`, so a host program's framebuffer, viewport, tests, blend,
culling, polygon mode, bindings (textures and sampler objects), masks and clear values are as it
left them, and moderngl's cached view of them agrees with the driver. Reads go through the driver
(glGet*, glIsEnabled) rather than moderngl's bookkeeping, so state the host set by any means is
kept. The body starts from `passes.neutral`, so none of the host's state reaches dentdemo's draws
and clears."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import astuple, dataclass
from typing import Any, cast

import moderngl

from dentdemo.gl.context import check_current, parking_framebuffer
from dentdemo.gl.library import gl_library as _gl
from dentdemo.gl.passes import NEUTRAL, OFF, TEXTURE_UNITS, Blend

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
    "polygon_offset_line": 0x2A02,
    "polygon_offset_point": 0x2A01,
    "depth_clamp": 0x864F,
    "primitive_restart": 0x8F9D,
    "color_logic_op": 0x0BF2,
    "sample_alpha_to_coverage": 0x809E,
    "sample_coverage": 0x80A0,
    "sample_mask": 0x8E51,
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
FLOATS = {
    "point_size": (0x0B11, 1),
    "polygon_offset": (0x8038, 1),
    "polygon_units": (0x2A00, 1),
    "clear_color": (0x0C22, 4),  # RGBA
}
#: Read as doubles: glClearDepth takes one (0 near .. 1 far).
DOUBLES = {"clear_depth": (0x0B73, 1)}
#: Bindings kept on each of the texture units 0 .. TEXTURE_UNITS - 1 (glGetIntegerv while the unit
#: is active): the 2D texture and the sampler object.
UNIT_BINDINGS = {"texture_2d": 0x8069, "sampler": 0x8919}
_TEXTURE0 = 0x84C0
_UNIFORM_BUFFER = 0x8A11
#: Uniform-buffer bindings kept (the carve's job table at 0, its texel rectangles at 1).
UNIFORM_BINDINGS = (0, 1)
_UNIFORM_BUFFER_BINDING, _UNIFORM_BUFFER_START, _UNIFORM_BUFFER_SIZE = 0x8A28, 0x8A29, 0x8A2A
_TEXTURE_2D = 0x0DE1
_FRONT_AND_BACK = 0x0408
_LINE = 0x1B01
_FILL = 0x1B02
#: moderngl's names for GL's values (the strings its setters take).
_COMPARE_NAMES = {
    0x0200: "0",
    0x0201: "<",
    0x0202: "==",
    0x0203: "<=",
    0x0204: ">",
    0x0205: "!=",
    0x0206: ">=",
    0x0207: "1",
}
_FACE_NAMES = {0x0404: "front", 0x0405: "back", 0x0408: "front_and_back"}
_WINDING_NAMES = {0x0900: "cw", 0x0901: "ccw"}
#: moderngl's enable flags by the capability each stands for.
_FLAGS = {
    "blend": moderngl.BLEND,
    "depth_test": moderngl.DEPTH_TEST,
    "cull_face": moderngl.CULL_FACE,
    "rasterizer_discard": moderngl.RASTERIZER_DISCARD,
    "program_point_size": moderngl.PROGRAM_POINT_SIZE,
}


@dataclass(frozen=True)
class GLState:
    """A snapshot of the state above (values as GL reports them)."""

    enabled: dict[str, bool]
    integers: dict[str, tuple[int, ...]]
    booleans: dict[str, tuple[bool, ...]]
    floats: dict[str, tuple[float, ...]]
    doubles: dict[str, tuple[float, ...]]
    #: Per binding of UNIT_BINDINGS, the object name on each unit.
    units: dict[str, tuple[int, ...]]
    #: Uniform-buffer bindings 0 and 1 (the carve's job and rectangle tables): buffer, start and
    #: size in bytes (0: the whole buffer) each; and the generic GL_UNIFORM_BUFFER binding,
    #: which a range bind sets too.
    uniform_blocks: tuple[tuple[int, int, int], ...] = ()
    uniform_buffer: int = 0


def _get(getter: str, ctype: type[ctypes._SimpleCData[Any]], pname: int, count: int) -> tuple:
    """`count` values of `pname` through glGet{getter}v."""
    out = (ctype * 4)()
    getattr(_gl(), f"glGet{getter}v")(pname, out)
    return tuple(out[:count])


def capture(units: int = TEXTURE_UNITS) -> GLState:
    """The current context's state (it must be current), with the bindings of texture units
    0 .. `units` - 1."""
    gl = _gl()
    enabled = {name: bool(gl.glIsEnabled(cap)) for name, cap in CAPABILITIES.items()}
    integers = {name: _get("Integer", ctypes.c_int, *spec) for name, spec in INTEGERS.items()}
    per_unit: dict[str, list[int]] = {name: [] for name in UNIT_BINDINGS}
    for unit in range(units):
        gl.glActiveTexture(_TEXTURE0 + unit)
        for name, pname in UNIT_BINDINGS.items():
            per_unit[name].append(_get("Integer", ctypes.c_int, pname, 1)[0])
    gl.glActiveTexture(integers["active_texture"][0])
    blocks = []
    for binding in UNIFORM_BINDINGS:
        block = (ctypes.c_int * 1)()
        gl.glGetIntegeri_v(_UNIFORM_BUFFER_BINDING, binding, block)
        span = [(ctypes.c_int64 * 1)() for _ in range(2)]
        gl.glGetInteger64i_v(_UNIFORM_BUFFER_START, binding, span[0])
        gl.glGetInteger64i_v(_UNIFORM_BUFFER_SIZE, binding, span[1])
        blocks.append((block[0], span[0][0], span[1][0]))
    return GLState(
        enabled,
        integers,
        {
            name: tuple(map(bool, _get("Boolean", ctypes.c_ubyte, *b)))
            for name, b in BOOLEANS.items()
        },
        {name: _get("Float", ctypes.c_float, *spec) for name, spec in FLOATS.items()},
        {name: _get("Double", ctypes.c_double, *spec) for name, spec in DOUBLES.items()},
        {name: tuple(names) for name, names in per_unit.items()},
        tuple(blocks),
        _get("Integer", ctypes.c_int, _UNIFORM_BUFFER_BINDING, 1)[0],
    )


def _gl_value(names: dict[int, str], name: object) -> int:
    """GL's enum for moderngl's `name` of it."""
    return next(value for value, known in names.items() if known == name)


#: What `neutral` (`passes.NEUTRAL`) sets, as GL reports it: the capabilities it switches off
#: (`OFF`, the clip distances and moderngl's enable flags: all but multisampling), and the
#: values it gives the integer state and the blend it sets.
_NEUTRAL_OFF = frozenset(
    name
    for name, capability in CAPABILITIES.items()
    if capability in OFF or name.startswith("clip_distance") or name in _FLAGS
)
_NEUTRAL_INTEGERS = {
    "depth_func": (_gl_value(_COMPARE_NAMES, NEUTRAL["depth_func"]),),
    "cull_face_mode": (_gl_value(_FACE_NAMES, NEUTRAL["cull_face"]),),
    "front_face": (_gl_value(_WINDING_NAMES, NEUTRAL["front_face"]),),
}
_BLEND = (
    "blend_src_rgb",
    "blend_dst_rgb",
    "blend_src_alpha",
    "blend_dst_alpha",
    "blend_equation_rgb",
    "blend_equation_alpha",
)
_NEUTRAL_BLEND = astuple(cast(Blend, NEUTRAL["blend"]))
#: The capabilities `_record` sets exactly (through moderngl's enable flags).
_RECORDED = frozenset(_FLAGS)
#: Those `neutral` switches off directly (the enable flags go through moderngl).
_DIRECT_OFF = tuple(name for name in CAPABILITIES if name in _NEUTRAL_OFF and name not in _FLAGS)


def _blend(state: GLState) -> tuple[int, ...]:
    return tuple(state.integers[name][0] for name in _BLEND)


def to_neutral(ctx: moderngl.Context, state: GLState) -> None:
    """`passes.neutral` from `state` (the current state, as `capture` read it), setting only
    what differs (on the units `state` holds)."""
    gl, i = _gl(), state.integers
    if any(state.enabled[name] for name in _FLAGS):
        ctx.enable_only(0)  # none (through moderngl: its record)
    for name in _DIRECT_OFF:
        if state.enabled[name]:
            gl.glDisable(CAPABILITIES[name])
    if i["depth_func"] != _NEUTRAL_INTEGERS["depth_func"]:
        ctx.depth_func = str(NEUTRAL["depth_func"])
    if i["cull_face_mode"] != _NEUTRAL_INTEGERS["cull_face_mode"]:
        ctx.cull_face = str(NEUTRAL["cull_face"])
    if i["front_face"] != _NEUTRAL_INTEGERS["front_face"]:
        ctx.front_face = str(NEUTRAL["front_face"])
    if _blend(state) != _NEUTRAL_BLEND:
        gl.glBlendFuncSeparate(*_NEUTRAL_BLEND[:4])
        gl.glBlendEquationSeparate(*_NEUTRAL_BLEND[4:])
    if i["polygon_mode"][0] != _FILL:
        ctx.wireframe = bool(NEUTRAL["wireframe"])
    for unit, sampler in enumerate(state.units["sampler"]):
        if sampler:
            ctx.clear_samplers(unit, unit + 1)


def restore(state: GLState, from_neutral: bool = False) -> None:
    """Put `state` back in the current context (after `_record`, which sets part of it through
    moderngl). `from_neutral`: the context is in `passes.neutral` state but for what `_record`
    set, so only what differs from that is set (and the bindings of the units `state` holds)."""
    gl, i = _gl(), state.integers
    for name, cap in CAPABILITIES.items():
        on = state.enabled[name]
        if from_neutral and (name in _RECORDED or (not on and name in _NEUTRAL_OFF)):
            # `_record`'s polygon offset and scissor switch these (a scissor of None: off).
            if not name.startswith("polygon_offset") and name != "scissor_test":
                continue
        (gl.glEnable if on else gl.glDisable)(cap)
    if not from_neutral:  # else `_record` set them, exactly
        gl.glDepthFunc(i["depth_func"][0])
        gl.glCullFace(i["cull_face_mode"][0])
        gl.glFrontFace(i["front_face"][0])
        gl.glViewport(*i["viewport"])
    if not (from_neutral and _blend(state) == _NEUTRAL_BLEND):
        gl.glBlendFuncSeparate(
            i["blend_src_rgb"][0],
            i["blend_dst_rgb"][0],
            i["blend_src_alpha"][0],
            i["blend_dst_alpha"][0],
        )
        gl.glBlendEquationSeparate(i["blend_equation_rgb"][0], i["blend_equation_alpha"][0])
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
    if not (from_neutral and i["polygon_mode"][0] in (_LINE, _FILL)):  # `_record`'s wireframe
        gl.glPolygonMode(_FRONT_AND_BACK, i["polygon_mode"][0])
    bindings = zip(state.units["texture_2d"], state.units["sampler"], strict=True)
    for unit, (texture, sampler) in enumerate(bindings):
        gl.glActiveTexture(_TEXTURE0 + unit)
        gl.glBindTexture(_TEXTURE_2D, alive("glIsTexture", texture))
        gl.glBindSampler(unit, alive("glIsSampler", sampler))
    gl.glActiveTexture(i["active_texture"][0])
    for binding, (buffer, start, size) in zip(UNIFORM_BINDINGS, state.uniform_blocks, strict=True):
        buffer = alive("glIsBuffer", buffer)
        if buffer and size > 0:
            gl.glBindBufferRange(
                _UNIFORM_BUFFER, binding, buffer, ctypes.c_ssize_t(start), ctypes.c_ssize_t(size)
            )
        else:
            gl.glBindBufferBase(_UNIFORM_BUFFER, binding, buffer)
    gl.glBindBuffer(_UNIFORM_BUFFER, alive("glIsBuffer", state.uniform_buffer))
    gl.glDepthMask(ctypes.c_ubyte(state.booleans["depth_mask"][0]))
    gl.glColorMask(*(ctypes.c_ubyte(v) for v in state.booleans["color_mask"]))
    gl.glPointSize(ctypes.c_float(state.floats["point_size"][0]))
    gl.glPolygonOffset(
        ctypes.c_float(state.floats["polygon_offset"][0]),
        ctypes.c_float(state.floats["polygon_units"][0]),
    )
    gl.glClearColor(*(ctypes.c_float(c) for c in state.floats["clear_color"]))
    gl.glClearDepth(ctypes.c_double(state.doubles["clear_depth"][0]))


def _record(ctx: moderngl.Context, state: GLState) -> None:
    """Make moderngl's cached view of the context (what its setters keep in the Context: enable
    flags, depth function, cull and front face, wireframe, polygon offset, and the bound
    framebuffer's viewport and scissor) say what `state` holds, by setting each through moderngl.
    Each setter also makes its GL call; `restore` afterwards sets GL exactly (a scissor of None
    resets the box, a polygon offset switches the offset capabilities)."""
    on, i, f = state.enabled, state.integers, state.floats
    ctx.enable_only(sum(flag for name, flag in _FLAGS.items() if on[name]))
    ctx.depth_func = _COMPARE_NAMES[i["depth_func"][0]]
    ctx.cull_face = _FACE_NAMES[i["cull_face_mode"][0]]
    ctx.front_face = _WINDING_NAMES[i["front_face"][0]]
    ctx.wireframe = i["polygon_mode"][0] == _LINE  # GL_POINT has no name in moderngl
    ctx.polygon_offset = (f["polygon_offset"][0], f["polygon_units"][0])
    x, y, width, height = i["viewport"]
    ctx.viewport = (x, y, width, height)
    x, y, width, height = i["scissor_box"]
    ctx.scissor = (x, y, width, height) if on["scissor_test"] else None


@contextmanager
def preserved(
    ctx: moderngl.Context, units: int = TEXTURE_UNITS, leaves_neutral: bool = False
) -> Iterator[None]:
    """Run the body from `passes.neutral`, then give the host back its GL state and moderngl's
    cached view of it (the bound framebuffer object and the rest `_record` names). ContextError
    first, before any GL call, where `ctx` is not the context current in this thread: GL would
    read another context's state (or none: zeros, in a thread with no current context).

    `units`: the body binds textures and sampler objects on units 0 .. `units` - 1 only, so
    only those are kept (and start with no sampler object). `leaves_neutral`: the body ends in
    `passes.neutral` state (the carve's batches do), so only what differs from it is put back.
    Either way, the neutral state is reached from the host's setting only what differs."""
    check_current(ctx, "dentdemo")
    fbo = ctx.fbo
    state = capture(units)
    to_neutral(ctx, state)
    try:
        yield
    finally:
        # moderngl's record of the binding (it re-binds it whenever it makes a framebuffer):
        # the host's, or, where the host never bound one, a framebuffer that is never released.
        (fbo if fbo is not None else parking_framebuffer(ctx)).use()
        _record(ctx, state)
        restore(state, leaves_neutral)  # GL's own binding and the rest, exactly
