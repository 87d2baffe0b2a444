"""A host program's GL state neither changes the carve's result nor comes back changed: under
hostile state (wireframe, trilinear or nearest sampler objects on every unit, odd clear values,
culling, depth, blend and rasterizer settings, an `extra` of its own) the dent is the analytic
spherical cap and the same bits as under clean state, the driver holds after every public call
what it held before, moderngl's cached view of the context agrees with the driver, and ctx.extra
is the host's. Every read here is a raw glGet through ctypes, independent of dentdemo.gl.state."""

from __future__ import annotations

import ctypes
import gc
import os
import weakref
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import replace

import moderngl
import numpy as np
import pytest

import dentdemo
from dentdemo.carve.carver import Carver

#: The press: a ball of radius R (m) posed touching the top of a plate of side S (m) at the
#: origin, pressed D (m) into it (and dented TOOL_D m itself).
R, S, D, TOOL_D = 0.05, 0.4, 0.004, 0.001
MAP = 256  # texels a side of the plate's map
UNITS = 8  # texture units whose sampler and texture bindings are checked
HOST_CLEAR_COLOR = (0.3, 0.6, 0.9, 0.2)
HOST_CLEAR_DEPTH = 0.25

# GL enums.
_CAPS = {
    "blend": 0x0BE2,
    "cull_face": 0x0B44,
    "depth_test": 0x0B71,
    "scissor_test": 0x0C11,
    "stencil_test": 0x0B90,
    "polygon_offset_fill": 0x8037,
    "polygon_offset_line": 0x2A02,
    "polygon_offset_point": 0x2A01,
    "depth_clamp": 0x864F,
    "program_point_size": 0x8642,
    "rasterizer_discard": 0x8C89,
    "clip_distance0": 0x3000,
}
_INTS = {
    "depth_func": (0x0B74, 1),
    "cull_face_mode": (0x0B45, 1),
    "front_face": (0x0B46, 1),
    "polygon_mode": (0x0B40, 2),
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
    "active_texture": (0x84E0, 1),
}
_FLOATS = {
    "clear_color": (0x0C22, 4),
    "point_size": (0x0B11, 1),
    "polygon_offset_factor": (0x8038, 1),
    "polygon_offset_units": (0x2A00, 1),
}
_BOOLS = {"depth_mask": (0x0B72, 1), "color_mask": (0x0C23, 4)}
_DEPTH_CLEAR_VALUE = 0x0B73
_TEXTURE0, _TEXTURE_BINDING_2D, _SAMPLER_BINDING = 0x84C0, 0x8069, 0x8919
_LINE = 0x1B01
_UNIFORM_BUFFER_BINDING, _UNIFORM_BUFFER_START, _UNIFORM_BUFFER_SIZE = 0x8A28, 0x8A29, 0x8A2A
_CULL_NAMES = {0x0404: "front", 0x0405: "back", 0x0408: "front_and_back"}
_FRONT_NAMES = {0x0900: "cw", 0x0901: "ccw"}
_DEPTH_NAMES = {
    0x0200: "0",
    0x0201: "<",
    0x0202: "==",
    0x0203: "<=",
    0x0204: ">",
    0x0205: "!=",
    0x0206: ">=",
    0x0207: "1",
}


# -- raw reads -------------------------------------------------------------------------------------
def _raw() -> ctypes.CDLL:
    gl = ctypes.CDLL("libOpenGL.so.0")
    gl.glIsEnabled.restype = ctypes.c_ubyte
    return gl


def _read(getter: Callable, ctype: type, pname: int, count: int) -> tuple:
    out = (ctype * 4)()
    getter(pname, out)
    return tuple(out[:count])


def _per_unit(gl: ctypes.CDLL, pname: int) -> tuple[int, ...]:
    """An integer binding on each of units 0..UNITS-1 (the active unit is put back)."""
    active = _read(gl.glGetIntegerv, ctypes.c_int, _INTS["active_texture"][0], 1)[0]
    values = []
    for unit in range(UNITS):
        gl.glActiveTexture(_TEXTURE0 + unit)
        values.append(_read(gl.glGetIntegerv, ctypes.c_int, pname, 1)[0])
    gl.glActiveTexture(active)
    return tuple(values)


def driver_state() -> dict[str, object]:
    """What the driver holds, read with glGet* (clear depth as a double)."""
    gl = _raw()
    state: dict[str, object] = {name: bool(gl.glIsEnabled(cap)) for name, cap in _CAPS.items()}
    state |= {n: _read(gl.glGetIntegerv, ctypes.c_int, *spec) for n, spec in _INTS.items()}
    state |= {n: _read(gl.glGetFloatv, ctypes.c_float, *spec) for n, spec in _FLOATS.items()}
    state |= {n: _read(gl.glGetBooleanv, ctypes.c_ubyte, *spec) for n, spec in _BOOLS.items()}
    state["clear_depth"] = _read(gl.glGetDoublev, ctypes.c_double, _DEPTH_CLEAR_VALUE, 1)
    state["textures"] = _per_unit(gl, _TEXTURE_BINDING_2D)
    state["samplers"] = _per_unit(gl, _SAMPLER_BINDING)
    # Uniform-buffer bindings 0 and 1 (the carve binds its tables there by range), the generic one.
    for binding in (0, 1):
        block = (ctypes.c_int * 1)()
        gl.glGetIntegeri_v(_UNIFORM_BUFFER_BINDING, binding, block)
        span = [(ctypes.c_int64 * 1)() for _ in range(2)]
        gl.glGetInteger64i_v(_UNIFORM_BUFFER_START, binding, span[0])
        gl.glGetInteger64i_v(_UNIFORM_BUFFER_SIZE, binding, span[1])
        state[f"uniform_block{binding}"] = (block[0], span[0][0], span[1][0])
    state["uniform_buffer"] = _read(gl.glGetIntegerv, ctypes.c_int, _UNIFORM_BUFFER_BINDING, 1)
    return state


def cache_mismatches(ctx: moderngl.Context) -> dict[str, tuple[object, object]]:
    """moderngl's cached attributes that disagree with the driver: name -> (cached, driver).
    (blend_func and blend_equation have no readable record in moderngl: their getters raise.)"""
    d = driver_state()
    fbo = ctx.fbo
    pairs: dict[str, tuple[object, object]] = {
        "cull_face": (ctx.cull_face, _CULL_NAMES[d["cull_face_mode"][0]]),
        "front_face": (ctx.front_face, _FRONT_NAMES[d["front_face"][0]]),
        "wireframe": (ctx.wireframe, d["polygon_mode"][0] == _LINE),
        "depth_func": (ctx.mglo.depth_func, _DEPTH_NAMES[d["depth_func"][0]]),
        "viewport": (tuple(ctx.viewport), d["viewport"]),
        "fbo": (fbo.glo, d["draw_framebuffer"][0]),
        "point_size": (ctx.point_size, d["point_size"][0]),
        "polygon_offset": (
            tuple(ctx.polygon_offset),
            (d["polygon_offset_factor"][0], d["polygon_offset_units"][0]),
        ),
        "depth_mask": (bool(fbo.depth_mask), bool(d["depth_mask"][0])),
        "color_mask": (tuple(bool(v) for v in fbo.color_mask), tuple(map(bool, d["color_mask"]))),
    }
    if d["scissor_test"]:  # moderngl reports a scissor box only while the test is on
        pairs["scissor"] = (tuple(ctx.scissor), d["scissor_box"])
    return {name: pair for name, pair in pairs.items() if pair[0] != pair[1]}


# -- the press -------------------------------------------------------------------------------------
def host_read(texture: moderngl.Texture) -> np.ndarray:
    """A texture's bytes as the host reads them back (moderngl binds it on its default unit, 31,
    outside those checked, and leaves that unit active: the active unit is put back)."""
    gl = _raw()
    active = _read(gl.glGetIntegerv, ctypes.c_int, _INTS["active_texture"][0], 1)[0]
    data = np.frombuffer(texture.read(), np.uint8).copy()
    gl.glActiveTexture(active)
    return data


def press_and_read(
    ctx: moderngl.Context, check: Callable[[str], None]
) -> tuple[np.ndarray, np.ndarray]:
    """The plate's heights (float32 [v, u] m) and normal map bytes after the ball's press,
    `check(call)` after every public call; everything made is released."""
    plate = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Plate(S)), MAP)
    check("DentableSurface(plate)")
    ball = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Sphere(R)), 64)
    check("DentableSurface(ball)")
    ball.model = np.eye(4)
    ball.model[1, 3] = R  # touching the plate's top (y = 0) at the origin
    carver = dentdemo.Carver(ctx)
    check("Carver()")
    fresh = host_read(plate.normal)
    contact = dentdemo.Contact((0, 0, 0), (0, -1, 0))
    pressed = carver.press(plate, ball, contact, D, TOOL_D)
    check("press()")
    heights = plate.heights()
    check("heights()")
    normals = host_read(plate.normal)
    # Undo and repair under the same state put back the fresh maps exactly.
    assert carver.undo()
    check("undo()")
    assert not plate.heights().any() and np.array_equal(host_read(plate.normal), fresh)
    carver.press(plate, ball, contact, D, TOOL_D)
    carver.repair(plate)
    check("repair()")
    assert not plate.heights().any() and np.array_equal(host_read(plate.normal), fresh)
    for thing in (carver, ball, plate):
        thing.release()
        check(f"{type(thing).__name__}.release()")
    assert pressed
    return heights, normals


def analytic_cap() -> np.ndarray:
    """h(r) = min(0, -D + R - sqrt(R^2 - r^2)) at the texel centres (float64 [v, u] m): the
    plate maps x = (u - 0.5) S, z = (0.5 - v) S."""
    centres = (np.arange(MAP) + 0.5) / MAP
    u, v = np.meshgrid(centres, centres)  # [v, u]
    r2 = ((u - 0.5) * S) ** 2 + ((0.5 - v) * S) ** 2
    return np.minimum(0.0, -D + R - np.sqrt(np.maximum(R * R - r2, 0.0)))


_CLEAN: list[tuple[np.ndarray, np.ndarray]] = []


def clean_press(ctx: moderngl.Context) -> tuple[np.ndarray, np.ndarray]:
    """The same press under the context's default state (made once): heights, normal bytes."""
    if not _CLEAN:
        _CLEAN.append(press_and_read(ctx, lambda call: None))
    return _CLEAN[0]


# -- hostile host state ----------------------------------------------------------------------------
_SAMPLER_FILTERS = {
    "trilinear": (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR),
    "nearest": (moderngl.NEAREST, moderngl.NEAREST),
}


@contextmanager
def hostile_state(ctx: moderngl.Context, filters: tuple[int, int]) -> Iterator[None]:
    """A host mid-frame with every setting a pass might rely on changed; all undone after."""
    gl = _raw()
    target = ctx.framebuffer([ctx.texture((64, 48), 4)], ctx.depth_renderbuffer((64, 48)))
    sampler = ctx.sampler(filter=filters)
    textures = [ctx.texture((4, 4), 1) for _ in range(UNITS)]
    block = ctx.buffer(reserve=1024)
    block.bind_to_uniform_block(0, offset=256, size=512)  # the host's own ranges at bindings 0
    block.bind_to_uniform_block(1, offset=0, size=256)  # and 1
    target.use()
    ctx.viewport = (3, 5, 41, 37)
    ctx.scissor = (1, 2, 30, 20)
    ctx.enable(
        moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE | moderngl.RASTERIZER_DISCARD
    )
    ctx.depth_func = ">="
    ctx.blend_func = moderngl.SRC_COLOR, moderngl.DST_ALPHA
    ctx.blend_equation = moderngl.MAX
    ctx.cull_face = "front"
    ctx.front_face = "cw"
    ctx.wireframe = True
    ctx.point_size = 4.0
    ctx.polygon_offset = (1.5, 2.0)
    ctx.enable_direct(0x3000)  # GL_CLIP_DISTANCE0
    ctx.enable_direct(_CAPS["depth_clamp"])
    for unit, texture in enumerate(textures):
        texture.use(unit)
        sampler.use(unit)
    gl.glActiveTexture(_TEXTURE0 + 3)
    gl.glClearColor(*(ctypes.c_float(c) for c in HOST_CLEAR_COLOR))
    gl.glClearDepth(ctypes.c_double(HOST_CLEAR_DEPTH))
    try:
        yield
    finally:
        ctx.clear_samplers(0, UNITS)
        ctx.disable_direct(0x3000)
        ctx.disable_direct(_CAPS["depth_clamp"])
        ctx.polygon_offset = (0.0, 0.0)
        ctx.wireframe = False
        ctx.disable(moderngl.RASTERIZER_DISCARD)
        gl.glActiveTexture(_TEXTURE0)
        gl.glClearColor(*(ctypes.c_float(0.0) for _ in range(4)))
        gl.glClearDepth(ctypes.c_double(1.0))
        for thing in (sampler, *textures, block):
            thing.release()
        from dentdemo.gl.context import release

        release(target)


def _state_checker(ctx: moderngl.Context, extra: object) -> Callable[[str], None]:
    """After a public call: the driver's state as before the first, moderngl's cache agreeing
    with it, and ctx.extra the host's own object with its own keys."""
    before = driver_state()
    keys = set(extra) if isinstance(extra, dict) else None
    assert not cache_mismatches(ctx), "the oracle: the host's own settings agree with moderngl"

    def check(call: str) -> None:
        after = driver_state()
        problems = []
        changed = {k: (before[k], after[k]) for k in before if before[k] != after[k]}
        if changed:
            problems.append(f"the driver's state changed (before, after): {changed}")
        stale = cache_mismatches(ctx)
        if stale:
            problems.append(f"moderngl's cache disagrees with the driver (cached, driver): {stale}")
        if ctx.extra is not extra:
            problems.append(f"ctx.extra was replaced with a {type(ctx.extra).__name__}")
        elif keys is not None and set(extra) != keys:
            problems.append(f"ctx.extra's keys changed to {sorted(extra)}")
        assert not problems, f"after {call}: " + "; ".join(problems)

    return check


class _HostExtra:
    """A host's own non-dict ctx.extra."""


def assert_cap(heights: np.ndarray) -> None:
    """`heights` is the analytic cap: the swept sphere is exact, so within 1 um at every texel
    centre, dented exactly where the cap is, D deep at the deepest texel."""
    cap = analytic_cap()
    error = np.abs(heights.astype(np.float64) - cap)
    assert float(error.max()) < 1e-6, (
        f"the dent is off the analytic cap by up to {float(error.max()) * 1e3:.3f} mm over "
        f"{int((error >= 1e-6).sum())} texels; dented {int((heights < 0).sum())} texels, the "
        f"cap {int((cap < 0).sum())}"
    )
    assert np.array_equal(heights < 0, cap < 0)
    assert float(heights.min()) == pytest.approx(float(cap.min()), abs=1e-6)


@pytest.mark.parametrize("extra_kind", ["object", "dict"])
@pytest.mark.parametrize("sampler_kind", list(_SAMPLER_FILTERS))
def test_hostile_host_state_neither_changes_the_dent_nor_is_changed(gl, sampler_kind, extra_kind):
    ctx = gl.ctx
    expected, expected_normals = clean_press(ctx)
    saved_extra = ctx.extra
    extra: object = _HostExtra() if extra_kind == "object" else {"host": 1}
    ctx.extra = extra
    try:
        with hostile_state(ctx, _SAMPLER_FILTERS[sampler_kind]):
            heights, normals = press_and_read(ctx, _state_checker(ctx, extra))
    finally:
        ctx.extra = saved_extra
    assert heights.dtype == np.float32 and heights.shape == (MAP, MAP)
    assert_cap(heights)
    assert np.array_equal(heights, expected), (
        f"{int((heights != expected).sum())} texels differ from the clean press, by up to "
        f"{float(np.abs(heights - expected).max()) * 1e3:.3f} mm"
    )
    assert np.array_equal(normals, expected_normals), (
        f"{int((normals != expected_normals).sum())} bytes of the normal map differ from the "
        "clean press"
    )


def test_a_carver_that_gives_no_state_back_dents_as_under_clean_state(gl):
    """The sandbox's carver (keep_host_state False: it owns its context) under the hostile
    state: the same heights and normal map as the clean press, bit for bit, and the batch's
    passes leave the neutral state (no blending, depth test, culling, rasterizer discard or
    scissor test)."""
    ctx = gl.ctx
    expected, expected_normals = clean_press(ctx)
    gl_raw = _raw()
    plate = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Plate(S)), MAP)
    ball = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Sphere(R)), 64)
    ball.model = np.eye(4)
    ball.model[1, 3] = R
    carver = dentdemo.Carver(ctx)
    inner = carver._live()
    carver._carver = Carver(inner.gl, replace(inner.options, keep_host_state=False))
    inner.release()
    contact = dentdemo.Contact((0, 0, 0), (0, -1, 0))
    try:
        with hostile_state(ctx, _SAMPLER_FILTERS["trilinear"]):
            carver.press(plate, ball, contact, D, TOOL_D)
            left = {name: bool(gl_raw.glIsEnabled(_CAPS[name])) for name in _NEUTRAL_OFF}
            heights, normals = plate.heights(), host_read(plate.normal)
    finally:
        for thing in (carver, ball, plate):
            thing.release()
    assert left == dict.fromkeys(_NEUTRAL_OFF, False)
    assert np.array_equal(heights, expected) and np.array_equal(normals, expected_normals)


#: Capabilities the hostile state switches on and the neutral state off.
_NEUTRAL_OFF = ("blend", "depth_test", "cull_face", "rasterizer_discard", "scissor_test")


def test_the_clean_press_is_the_analytic_cap(gl):
    assert_cap(clean_press(gl.ctx)[0])


def test_dentdemo_keeps_no_host_context_alive(gl):
    """dentdemo's per-context objects live with the context, not in a table that outlives it:
    a host's context that used the API is collected once the host drops it."""
    from dentdemo.gl.context import create_headless

    ctx = create_headless(os.environ.get("DENTDEMO_GL_BACKEND", "egl")).ctx
    plate = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Plate(S)), 16)
    carver = dentdemo.Carver(ctx)
    assert ctx.extra is None
    carver.release()
    plate.release()
    ctx.release()
    collected = weakref.ref(ctx)
    del ctx, plate, carver
    gc.collect()
    gl.make_current()
    assert collected() is None
