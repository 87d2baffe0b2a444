"""Render passes as small objects: a program, the fixed-function state it runs under (declared once,
not set by hand at each call site) and the textures it samples. The carve and the renderer both
draw through `Pass.run`.

A pass sets every piece of state its result depends on, whatever the state before it (a host
program's, or another pass's): depth test, function and mask; culling and front face; blending;
clip distances; polygon mode (filled unless declared); the sampler object on each texture unit it
reads (its own, or none, so that the texture's own filter and wrap apply); and it switches off the
tests and modes no pass declares (scissor, stencil, polygon offset, depth clamp, primitive
restart, logic op, sample coverage and mask, sRGB writes). Afterwards it leaves `neutral` state
(moderngl's defaults for what it declared, so moderngl's record of the context matches the
driver), with the bound framebuffer's depth mask. Passes run one after another under
`held_state` set only what differs from the pass before (and bind only the textures a unit does
not hold), and the neutral state comes back once, after the last. Restoring a host's own state
is `gl.state.preserved`'s job, at the public entry points; it starts them from `neutral` too."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from typing import Any

import moderngl

from dentdemo.gl.library import gl_library
from dentdemo.gl.shaders import set_uniform, set_uniforms

GL_CLIP_DISTANCE0 = 0x3000
#: Clip distances a pass may enable (GL 3.3 guarantees at least 8).
MAX_CLIP_DISTANCES = 8
#: Texture units a pass may read: 0 .. TEXTURE_UNITS - 1 (the carve reads at most three).
TEXTURE_UNITS = 8
#: Capabilities no pass declares, kept off during every pass (glDisable): scissor and stencil
#: tests, polygon offset (fill, line, point), depth clamp, primitive restart, logic op,
#: alpha-to-coverage, sample coverage, sample mask, sRGB framebuffer writes.
OFF = (
    0x0C11,  # GL_SCISSOR_TEST
    0x0B90,  # GL_STENCIL_TEST
    0x8037,  # GL_POLYGON_OFFSET_FILL
    0x2A02,  # GL_POLYGON_OFFSET_LINE
    0x2A01,  # GL_POLYGON_OFFSET_POINT
    0x864F,  # GL_DEPTH_CLAMP
    0x8F9D,  # GL_PRIMITIVE_RESTART
    0x0BF2,  # GL_COLOR_LOGIC_OP
    0x809E,  # GL_SAMPLE_ALPHA_TO_COVERAGE
    0x80A0,  # GL_SAMPLE_COVERAGE
    0x8E51,  # GL_SAMPLE_MASK
    0x8DB9,  # GL_FRAMEBUFFER_SRGB
)


@dataclass(frozen=True)
class Blend:
    """Blend factors and equations (glBlendFuncSeparate, glBlendEquationSeparate), moderngl's
    constants: out = equation(src_factor * fragment, dst_factor * framebuffer)."""

    src_rgb: int
    dst_rgb: int
    src_alpha: int
    dst_alpha: int
    equation_rgb: int = moderngl.FUNC_ADD
    equation_alpha: int = moderngl.FUNC_ADD


#: out = min(fragment, framebuffer) (MIN ignores the factors): dents only deepen.
MIN_BLEND = Blend(
    moderngl.ONE, moderngl.ONE, moderngl.ONE, moderngl.ONE, moderngl.MIN, moderngl.MIN
)
#: Ordinary "over" compositing: out = a * fragment + (1 - a) * framebuffer (a: fragment alpha).
ALPHA_BLEND = Blend(
    moderngl.SRC_ALPHA,
    moderngl.ONE_MINUS_SRC_ALPHA,
    moderngl.SRC_ALPHA,
    moderngl.ONE_MINUS_SRC_ALPHA,
)
#: moderngl's default factors and equation, put back after a pass that blends (`neutral`).
DEFAULT_BLEND = ALPHA_BLEND


@dataclass(frozen=True)
class PassState:
    """Fixed-function state of one pass; what is not named is off (or GL's default)."""

    depth_test: bool = False
    #: GL depth function while the depth test is on ("<" nearest wins, ">" farthest wins, ...).
    depth_func: str = "<"
    #: Whether the pass writes depth (glDepthMask).
    depth_write: bool = True
    #: Which faces to drop: "back", "front" or None (keep both).
    cull: str | None = None
    #: Winding of a front face: "ccw" (GL's default) or "cw".
    front_face: str = "ccw"
    #: Blend factors and equations, or None (no blending: the fragment replaces).
    blend: Blend | None = None
    #: gl_ClipDistance[0 .. n-1] are enabled, the rest of the 8 disabled.
    clip_distances: int = 0
    #: Draw triangle edges only (glPolygonMode LINE); filled otherwise, whatever the host set.
    wireframe: bool = False


class HeldState:
    """The fixed-function state that a run of passes has set (`held_state`): each pass applies
    only what differs from what the passes before it set, where each used to set all of it and
    put back `neutral` after it. What it does not know (at first, or after `forget`) it sets;
    `neutral` True: the run starts from `neutral` state (on texture units 0 .. `units` - 1),
    so only what a pass sets otherwise is set, and only that is put back at its end."""

    def __init__(
        self, ctx: moderngl.Context, neutral: bool = False, units: int = TEXTURE_UNITS
    ) -> None:
        self._ctx = ctx
        #: The value each setting was given, by name ("off": `OFF` switched off); empty:
        #: nothing known.
        self._held: dict[str, object] = dict(NEUTRAL) if neutral else {}
        #: What each texture unit holds, as `shared_batch` bound it (its sampler object too).
        self.units: dict[int, Sampled] = {}
        #: The units known to have no sampler object bound (`bind` need not unbind one).
        self.bare: set[int] = set(range(units)) if neutral else set()
        #: The units `leave` clears where not `bare`: the run's own, or after `forget` (or
        #: when nothing was known) every unit `neutral` clears.
        self._units = units if neutral else TEXTURE_UNITS
        #: The depth mask as last set (binding a framebuffer sets its own), or None: unknown.
        self.depth_mask: bool | None = None

    def forget(self) -> None:
        """Something else may have set state since (a host's work between passes)."""
        self._held.clear()
        self.units.clear()
        self.bare.clear()
        self._units = TEXTURE_UNITS
        self.depth_mask = None

    def apply(self, state: PassState, depth: bool = True) -> None:
        """Set `state` (after the pass's framebuffer is bound: binding one applies its own
        colour and depth masks and switches the scissor test off; `depth` False: it has no
        depth buffer, so the depth mask is left as binding it set it). A depth function, cull
        face or blend is left as it was where its test is off."""
        flags = (
            (moderngl.DEPTH_TEST if state.depth_test else 0)
            | (moderngl.CULL_FACE if state.cull else 0)
            | (moderngl.BLEND if state.blend is not None else 0)
        )
        values: dict[str, object] = {
            "off": True,
            "flags": flags,
            "depth_func": state.depth_func if state.depth_test else None,
            "cull_face": state.cull,
            "front_face": state.front_face,
            "blend": state.blend,
            "wireframe": state.wireframe,
            **{f"clip{i}": i < state.clip_distances for i in range(MAX_CLIP_DISTANCES)},
        }
        self._set(values)
        if depth:
            self.set_depth_mask(state.depth_write)

    def set_depth_mask(self, on: bool) -> None:
        if self.depth_mask is not on:
            gl_library().glDepthMask(int(on))
            self.depth_mask = on

    def _set(self, values: dict[str, object]) -> None:
        """Set each of `values` (None: leave it) that differs from what is held."""
        held = self._held
        for name, value in values.items():
            if value is not None and held.get(name, _UNKNOWN) != value:
                _SETTERS[name](self._ctx, value)
                held[name] = value

    def leave(self) -> None:
        """Put back `neutral` state: each setting not known to hold its neutral value (after
        `forget`, those the passes since have not set), and no sampler object on the units not
        known to have none, a run of such units in one call."""
        self._set(NEUTRAL)
        unit, last = 0, self._units
        while unit < last:
            if unit in self.bare:
                unit += 1
                continue
            end = unit + 1
            while end < last and end not in self.bare:
                end += 1
            self._ctx.clear_samplers(unit, end)
            self.bare.update(range(unit, end))
            unit = end


_UNKNOWN = object()


def _clip_setter(i: int) -> Callable[[moderngl.Context, bool], None]:
    return lambda ctx, on: _clip_distance(i, on)


#: How each setting `HeldState` keeps is set: setter(ctx, value) (through the context's own
#: methods, looked up at each call, as `bench.glcount` counts them).
_SETTERS: dict[str, Callable[[moderngl.Context, Any], None]] = {
    "off": lambda ctx, _: _switch_off(),
    # enable_only also switches off rasterizer discard and program point size.
    "flags": lambda ctx, flags: ctx.enable_only(flags),
    "depth_func": lambda ctx, func: setattr(ctx, "depth_func", func),
    "cull_face": lambda ctx, face: setattr(ctx, "cull_face", face),
    "front_face": lambda ctx, face: setattr(ctx, "front_face", face),
    "blend": lambda ctx, blend: _set_blend(blend),
    "wireframe": lambda ctx, on: setattr(ctx, "wireframe", on),
    **{f"clip{i}": _clip_setter(i) for i in range(MAX_CLIP_DISTANCES)},
}


def _switch_off() -> None:
    gl = gl_library()
    for capability in OFF:
        gl.glDisable(capability)


def _clip_distance(i: int, on: bool) -> None:
    gl = gl_library()
    (gl.glEnable if on else gl.glDisable)(GL_CLIP_DISTANCE0 + i)


@contextmanager
def held_state(
    ctx: moderngl.Context, neutral: bool = False, units: int = TEXTURE_UNITS
) -> Iterator[HeldState]:
    """Passes run one after another, each applying (`HeldState.apply`) only what differs from
    the one before; afterwards `neutral` state and the bound framebuffer's depth mask, once.
    `neutral` True: they start from `neutral` state (on units 0 .. `units` - 1: the passes
    bind no other), and only what they changed is put back."""
    held = HeldState(ctx, neutral, units)
    try:
        yield held
    finally:
        held.leave()
        fbo = ctx.fbo
        held.set_depth_mask(bool(fbo.depth_mask) if fbo is not None else True)


#: `neutral` state, by the names `HeldState` keeps it under and in moderngl's terms ("off":
#: `OFF` switched off; "flags": moderngl's enable flags, none on). `gl.state` reads GL's enums
#: for these from here.
NEUTRAL: dict[str, object] = {
    "off": True,
    "flags": 0,
    "depth_func": "<",
    "cull_face": "back",
    "front_face": "ccw",
    "blend": DEFAULT_BLEND,
    "wireframe": False,
    **{f"clip{i}": False for i in range(MAX_CLIP_DISTANCES)},
}


def neutral(ctx: moderngl.Context) -> None:
    """The state each pass leaves, whatever came before (`NEUTRAL`): moderngl's defaults for
    what a pass may declare (depth test, culling and blending off, depth function "<", cull
    face "back", front face "ccw", default blend, filled polygons), clip distances and the
    capabilities no pass declares off (with rasterizer discard and program point size), and no
    sampler object on units 0 .. TEXTURE_UNITS - 1. `gl.state.preserved` starts each public
    call from it, so draws and clears outside `Pass.run` (the chart mask, the environment
    bake) see none of the host's state either."""
    for name, value in NEUTRAL.items():
        _SETTERS[name](ctx, value)
    ctx.clear_samplers(0, TEXTURE_UNITS)


def _set_blend(blend: Blend) -> None:
    """Through GL directly: moderngl keeps no readable record of either."""
    gl = gl_library()
    gl.glBlendFuncSeparate(blend.src_rgb, blend.dst_rgb, blend.src_alpha, blend.dst_alpha)
    gl.glBlendEquationSeparate(blend.equation_rgb, blend.equation_alpha)


#: One draw of a pass in a batch: (viewport, draw, textures, uniforms), as `Pass.run` takes them.
Draw = Callable[..., None]

#: A texture a pass samples, alone (sampled through its own filter and wrap: any sampler object
#: on its unit is unbound) or with the sampler object to sample it through.
Sampled = moderngl.Texture | tuple[moderngl.Texture, moderngl.Sampler]


@dataclass(frozen=True)
class Pass:
    """One pass: `run` binds its textures to units 0, 1, ... and names them to the program's
    `samplers` in that order, sets `uniforms`, binds the framebuffer and viewport, applies the
    state and calls `draw(program)`."""

    name: str
    program: moderngl.Program
    state: PassState
    samplers: tuple[str, ...] = ()
    #: Keys of the uniforms given to `run` that pick the pass's variant and name no uniform.
    selectors: frozenset[str] = frozenset()

    def run(
        self,
        ctx: moderngl.Context,
        fbo: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int],
        draw: Callable[[moderngl.Program], None],
        textures: Sequence[Sampled] = (),
        uniforms: Mapping[str, object] | None = None,
    ) -> None:
        with self.batch(ctx, fbo) as one:
            one(viewport, draw, textures, uniforms)

    @contextmanager
    def batch(self, ctx: moderngl.Context, fbo: moderngl.Framebuffer) -> Iterator[Draw]:
        """The pass run many times into `fbo`, its state applied once: yields
        `one(viewport, draw, textures, uniforms, into=None)`, each call as `run` with those
        arguments; `into` draws into another framebuffer (bound when it changes, the state
        kept: a pass over many maps)."""
        with shared_batch(ctx, fbo, self.state) as one:
            yield partial(one, self)


#: One draw of a shared batch: `one(pass_, viewport, draw, textures, uniforms, into=None)`.
SharedDraw = Callable[..., None]


@contextmanager
def shared_batch(
    ctx: moderngl.Context,
    fbo: moderngl.Framebuffer,
    state: PassState,
    held: HeldState | None = None,
) -> Iterator[SharedDraw]:
    """Passes that share `state` (variants of one pass: programs built from one source with
    other defines) run many times, the state applied once: yields `one(pass_, viewport, draw,
    textures, uniforms, into=None)`, each call as `pass_.run` with those arguments into `fbo`,
    or into `into` (bound when it changes). Drawing a map's variants one after the other binds
    its framebuffer once, where a batch per variant would bind it once per variant. `held`:
    the state the passes before it set (`held_state`), which it applies the difference to and
    leaves set; without, it applies all of it and leaves `neutral` state."""
    bound = [fbo]
    #: What each texture unit holds since the batch bound it, and the viewport GL has (binding
    #: a framebuffer sets the viewport moderngl recorded for it): a draw sets again only what
    #: changed.
    #: The batch's draws alone set either meanwhile. A call that sets the same again is not
    #: free: Mesa marks the state changed, and llvmpipe's draw after it costs more.
    units: dict[int, Sampled] = held.units if held is not None else {}
    bare: set[int] = held.bare if held is not None else set()
    view: list[tuple[int, int, int, int] | None] = [None]
    named: dict[moderngl.Program, tuple[str, ...]] = {}  # the samplers named, by program

    def one(
        pass_: Pass,
        viewport: tuple[int, int, int, int],
        draw: Callable[[moderngl.Program], None],
        textures: Sequence[Sampled] = (),
        uniforms: Mapping[str, object] | None = None,
        into: moderngl.Framebuffer | None = None,
    ) -> None:
        if pass_.state is not state and pass_.state != state:
            raise ValueError(f"pass {pass_.name!r} has other state than its shared batch")
        if into is not None and into is not bound[0]:
            into.use()  # applies its own masks: the pass's depth mask again
            mask.depth_mask = bool(into.depth_mask)
            if into.depth_attachment is not None:
                mask.set_depth_mask(state.depth_write)
            bound[0] = into
            view[0] = _bound_viewport(into)
        prog = pass_.program
        if len(pass_.samplers) != len(textures):
            raise ValueError(f"pass {pass_.name!r} samples {len(pass_.samplers)} textures")
        for unit, sampled in enumerate(textures):
            if not _same(units.get(unit), sampled):
                bind(ctx, sampled, unit, bare)
                units[unit] = sampled
        if named.get(prog) != pass_.samplers:  # its samplers named to their units (GL keeps)
            for unit, name in enumerate(pass_.samplers):
                set_uniform(prog, name, unit)
            named[prog] = pass_.samplers
        if uniforms:
            set_uniforms(prog, uniforms, pass_.selectors)
        if viewport != view[0]:
            ctx.viewport = viewport
            view[0] = viewport
        draw(prog)

    fbo.use()
    view[0] = _bound_viewport(fbo)
    depth = fbo.depth_attachment is not None
    if held is None:
        with held_state(ctx) as mask:
            mask.depth_mask = bool(fbo.depth_mask)  # binding it set its own
            mask.apply(state, depth)
            yield one
    else:
        mask = held
        mask.depth_mask = bool(fbo.depth_mask)
        mask.apply(state, depth)
        yield one


def _same(held: Sampled | None, sampled: Sampled) -> bool:
    """Whether a unit that holds `held` already samples `sampled` (the same texture objects)."""
    if isinstance(sampled, tuple):
        return isinstance(held, tuple) and held[0] is sampled[0] and held[1] is sampled[1]
    return held is sampled


def _bound_viewport(fbo: moderngl.Framebuffer) -> tuple[int, int, int, int] | None:
    """The viewport GL has just after `fbo.use()`, or None where it is not known: the one
    moderngl recorded for a framebuffer object, which it sets when binding it unless that is
    empty (zero width or height: then GL keeps the one it had). The default framebuffer (a
    window's) is left unknown: older moderngl releases set no viewport when binding it."""
    x, y, width, height = fbo.viewport
    return (x, y, width, height) if width and height and fbo.glo else None


def bind(ctx: moderngl.Context, sampled: Sampled, unit: int, bare: set[int] | None = None) -> None:
    """Bind a texture to `unit` with its sampler object, or with none (the host's is unbound,
    unless `bare`, the units known to have none, holds `unit`; `bare` is kept up to date)."""
    if isinstance(sampled, tuple):
        texture, sampler = sampled
        texture.use(unit)
        sampler.use(unit)
        if bare is not None:
            bare.discard(unit)
    else:
        sampled.use(unit)
        if bare is None or unit not in bare:
            ctx.clear_samplers(unit, unit + 1)
        if bare is not None:
            bare.add(unit)
