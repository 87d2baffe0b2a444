"""What a batch asks of GL (docs/carve.md, "The job table", "Batches"): a burst of one ball
pressed at many spots of a plate draws the ball's swept quads of pass 3 instanced, not one draw a
hit, and each pass sets only the fixed-function state that differs from the pass before it,
where each used to set all of it and put it back. Oracle: the counts a burst's hits imply (one
quad per hit, in draws of at most one uniform-buffer range of the job table each), and the
capabilities no pass uses switched off a bounded number of times a batch, whatever its passes."""

from __future__ import annotations

import ctypes
import math
from collections import Counter

import moderngl
import numpy as np
import pytest

from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody, Carver, CarverOptions, Press
from dentdemo.carve.constants import JOB_ENTRIES
from dentdemo.gl.library import gl_library
from dentdemo.gl.passes import OFF
from dentdemo.model.shapes import Plate, Sphere
from gl_helpers import raw_gl_calls
from surface_helpers import Bodies, press_mesh, translation

DOWN = np.array([0.0, -1.0, 0.0])
RADIUS = 0.04


def _burst(bodies: Bodies, hits: int) -> list[Press]:
    """One ball body (one map) pressed at `hits` spots of a grid over a 1 m plate, dented
    itself too."""
    plate = bodies.make(press_mesh(Plate(1.0), 2), 512)
    ball = bodies.make(press_mesh(Sphere(RADIUS), 1), 128)
    side = math.ceil(math.sqrt(hits))
    presses = []
    for k in range(hits):
        x, z = ((k % side) - (side - 1) / 2) * 0.12, ((k // side) - (side - 1) / 2) * 0.12
        posed = CarveBody(ball.gpu_mesh, ball.maps, translation((x, RADIUS, z)))
        contact = ContactFrame(np.array([x, 0.0, z]), DOWN)
        presses.append(Press(plate, posed, contact, 0.004, 0.001))
    return presses


@pytest.mark.parametrize("hits", [1, 16, 36, 64])
def test_a_bursts_ball_quads_are_drawn_instanced(gl, monkeypatch, hits):
    """Pass 3 draws the ball of every hit as one quad (QUAD 1): all of them sample the one
    ball's map, so they are drawn in at most one draw per range of JOB_ENTRIES table entries
    they span, the instances adding up to one a hit."""
    bodies = Bodies(gl)
    carver = Carver(gl, CarverOptions(keep_host_state=False))
    quads = {carver._surface["peel", True, q].program.glo for q in (1, 2)}
    renders: list[int] = []
    real = moderngl.VertexArray.render

    def render(self, mode=None, vertices=-1, *, first=0, instances=-1):  # noqa: ANN001, ANN202
        if self.program.glo in quads:
            renders.append(max(instances, 1))
        return real(self, mode, vertices, first=first, instances=instances)

    try:
        presses = _burst(bodies, hits)
        carver.carve_many(presses)  # the vertex arrays made, the variants compiled
        monkeypatch.setattr(moderngl.VertexArray, "render", render)
        assert len(carver.carve_many(presses)) == 2 * hits
        assert sum(renders) == hits  # one quad a hit
        assert len(renders) <= 1 + (hits - 1) // JOB_ENTRIES + 1  # ranges the entries span
    finally:
        carver.release()
        bodies.release()


#: GL enums of what a hostile host's work switches on between the gathers and the normal
#: rebuilds (`meanwhile`), and of the sampler binding of the unit it binds a sampler to.
_HOSTILE = (0x0BE2, 0x0B71, 0x0B44, 0x0C11, 0x8C89, 0x3000 + 7)  # blend, depth test, cull
# face, scissor test, rasterizer discard, clip distance 7
_SAMPLER_BINDING, _ACTIVE_TEXTURE, _TEXTURE0 = 0x8919, 0x84E0, 0x84C0


@pytest.mark.parametrize("host_work", ["none", "gl", "cpu"])
def test_each_pass_sets_only_the_state_that_differs_from_the_last(gl, monkeypatch, host_work):
    """A batch of 16 hits runs passes 3, 4 and 5 (and pass 2 for every target with
    `address_every_target`). Each capability that no pass uses is switched off once, by the
    neutral state the batch starts from, and not again by the one it leaves (it knows they are
    off); with the host's GL work run meanwhile ("gl": `meanwhile` switches on what the passes
    leave off and binds a sampler object), once more by the first pass after it; with CPU
    work promised to make no GL call ("cpu": `meanwhile_uses_gl` False), not again. The six
    clip distances, which every carve pass enables alike, are switched on once for the batch
    (twice after the host's GL work) and off by the neutral state it starts from and, only
    where a pass left them on, the one it leaves. Whatever the host did, the batch leaves the
    neutral state: those capabilities off, no sampler object on any unit."""
    bodies = Bodies(gl)
    carver = Carver(gl, CarverOptions(keep_host_state=False, address_every_target=True))
    gl_ = gl_library()
    sampler = gl.ctx.sampler()
    enable = gl_.glEnable  # the host's own, not recorded

    def hostile() -> None:
        for cap in _HOSTILE:
            enable(cap)
        sampler.use(5)

    ran: list[bool] = []
    meanwhile = {"none": None, "gl": hostile, "cpu": lambda: ran.append(True)}[host_work]
    again = host_work == "gl"  # the state is set again after the host's work

    try:
        presses = _burst(bodies, 16)
        carver.carve_many(presses)
        with raw_gl_calls("glEnable", "glDisable") as made:
            carver.carve_many(presses, meanwhile=meanwhile, meanwhile_uses_gl=host_work != "cpu")
        calls = Counter((name, cap) for name, (cap,) in made)
        left_on = [hex(cap) for cap in (*OFF, *_HOSTILE) if gl_.glIsEnabled(cap)]
        bound = []
        for unit in range(8):
            gl_.glActiveTexture(_TEXTURE0 + unit)
            value = ctypes.c_int(-1)
            gl_.glGetIntegerv(_SAMPLER_BINDING, ctypes.byref(value))
            bound.append(value.value)
        gl_.glActiveTexture(_TEXTURE0)
        assert ran == ([True] if host_work == "cpu" else [])
        for cap in OFF:
            assert calls["glDisable", cap] == 1 + again, hex(cap)
        for k in range(6):  # GL_CLIP_DISTANCE0 + k
            assert calls["glEnable", 0x3000 + k] == 1 + again, k
            assert calls["glDisable", 0x3000 + k] <= 2, k
        assert left_on == []
        assert bound == [0] * 8
    finally:
        sampler.release()
        carver.release()
        bodies.release()


@pytest.mark.parametrize("hits", [16, 64])
def test_a_bursts_texel_rectangles_are_drawn_instanced(gl, monkeypatch, hits):
    """Passes 4 and 5 draw the ball's chart texels of every hit as rectangles (RECT: the bench's
    fine ball, rectangles always): one map, so each pass draws them in at most one draw per
    range of the job table their entries span (JOB_ENTRIES: every other entry is a ball's), and
    each pass draws at least one rectangle a hit."""
    from dentdemo.carve.carver import _Switches
    from dentdemo.carve.texel_passes import RECT

    bodies = Bodies(gl)
    carver = Carver(
        gl,
        CarverOptions(keep_host_state=False),
        _switches=_Switches(rect_texels_per_triangle=math.inf),
    )
    rects = {pass_.program.glo: key[0] for key, pass_ in carver._texel.items() if key[1] == RECT}
    renders: Counter[str] = Counter()
    instances: Counter[str] = Counter()
    real = moderngl.VertexArray.render

    def render(self, mode=None, vertices=-1, *, first=0, instances_=-1, **named):  # noqa: ANN001, ANN003, ANN202
        count = named.get("instances", instances_)
        name = rects.get(self.program.glo)
        if name is not None:
            renders[name] += 1
            instances[name] += max(count, 1)
        return real(self, mode, vertices, first=first, instances=count)

    try:
        presses = _burst(bodies, hits)
        carver.carve_many(presses)
        monkeypatch.setattr(moderngl.VertexArray, "render", render)
        assert len(carver.carve_many(presses)) == 2 * hits
        for name in ("gather", "normals"):
            assert instances[name] >= hits, name
            assert renders[name] <= math.ceil(2 * hits / JOB_ENTRIES), name
        assert instances["gather"] == instances["normals"]
    finally:
        carver.release()
        bodies.release()


def test_a_batchs_triangle_lists_are_one_upload_a_stream(gl, monkeypatch):
    """The triangle lists of a batch go to each index stream (a mesh's lists of one pass kind)
    in one upload, with the job table and the rectangles' table one each: the buffer writes of
    a batch do not grow with its hits."""
    bodies = Bodies(gl)
    carver = Carver(gl, CarverOptions(keep_host_state=False))
    writes = []
    real = moderngl.Buffer.write

    def write(self, *args, **named):  # noqa: ANN001, ANN002, ANN003, ANN202
        writes.append(self)
        return real(self, *args, **named)

    try:
        counts = []
        for hits in (4, 16, 36):
            presses = _burst(bodies, hits)
            carver.carve_many(presses)
            monkeypatch.setattr(moderngl.Buffer, "write", write)
            writes.clear()
            carver.carve_many(presses)
            monkeypatch.setattr(moderngl.Buffer, "write", real)
            counts.append(len(writes))
        # The plate's lists as a target and as a tool, the ball's gutter lists, two tables.
        assert counts[0] == counts[1] == counts[2] <= 6, counts
    finally:
        carver.release()
        bodies.release()


def _texel_renders(carver: Carver, presses: list[Press], monkeypatch) -> Counter[str]:
    """The draws of passes 4 and 5 drawn as triangle lists (not rectangles) when `presses` are
    carved a second time, by pass ("gather", "normals"), and their instances ("... instances")."""
    from dentdemo.carve.texel_passes import RECT

    lists = {pass_.program.glo: key[0] for key, pass_ in carver._texel.items() if key[1] != RECT}
    counts: Counter[str] = Counter()
    real = moderngl.VertexArray.render

    def render(self, mode=None, vertices=-1, first=0, instances=-1):  # noqa: ANN001, ANN202
        name = lists.get(self.program.glo)
        if name is not None:
            counts[name] += 1
            counts[f"{name} instances"] += max(instances, 1)
        return real(self, mode, vertices, first=first, instances=instances)

    carver.carve_many(presses)  # the vertex arrays made, the variants compiled
    monkeypatch.setattr(moderngl.VertexArray, "render", render)
    try:
        carver.carve_many(presses)
    finally:
        monkeypatch.setattr(moderngl.VertexArray, "render", real)
    return counts


@pytest.mark.parametrize("hits", [16, 64])
def test_one_maps_texel_lists_are_drawn_instanced(gl, monkeypatch, hits):
    """Passes 4 and 5 draw the plate's triangles of every hit (each hit's list its own: other
    triangles of the 2 x 2 plate; the ball's chart texels are rectangles, above) instanced over
    the hits: at most one draw a kind of list (chart, gutter) per range of JOB_ENTRIES entries
    the plate's jobs span, where they drew one a hit; every hit an instance."""
    bodies = Bodies(gl)
    carver = Carver(gl, CarverOptions(keep_host_state=False))
    try:
        counts = _texel_renders(carver, _burst(bodies, hits), monkeypatch)
        ranges = (hits - 1) // JOB_ENTRIES + 1  # the plate's entries: 0 .. hits - 1
        for name in ("gather", "normals"):
            assert counts[f"{name} instances"] >= hits, (name, counts)
            assert counts[name] <= 2 * ranges, (name, counts)
    finally:
        carver.release()
        bodies.release()


def test_a_union_of_lists_dents_as_each_its_own(gl, monkeypatch):
    """A burst whose plate lists differ from hit to hit, drawn as one instanced draw of their
    union (each instance clipped to its own footprint), writes the same height and normal bits
    as each hit's own list drawn alone."""
    from dentdemo.carve.carver import _Switches
    from surface_helpers import heights

    maps = []
    for per_draw in (math.inf, 0.0):  # always the union; never
        bodies = Bodies(gl)
        carver = Carver(
            gl,
            CarverOptions(keep_host_state=False),
            _switches=_Switches(union_triangles_per_draw=per_draw),
        )
        try:
            presses = _burst(bodies, 16)
            counts = _texel_renders(carver, presses, monkeypatch)
            assert (counts["gather"] <= 4) == (per_draw > 0), counts
            plate, ball = presses[0].target, presses[0].tool
            maps.append([(heights(gl, body), gl.read(body.maps.normal)) for body in (plate, ball)])
            assert (maps[-1][0][0] < -1e-4).sum() > 16 * 20  # every hit dented the plate
        finally:
            carver.release()
            bodies.release()
    for (ha, na), (hb, nb) in zip(*maps, strict=True):
        assert np.array_equal(ha, hb) and np.array_equal(na, nb)


@pytest.mark.slow
def test_a_bursts_gl_calls_are_bounded_and_barely_grow_with_its_hits():
    """The bench's press as a burst of 64 hits at 1024² asks GL for at most 200 calls a batch
    (`bench.glcount`, counted as the bench counts them, in a process of its own), and at most 16
    more than one hit alone: a hit adds an instance to draws that are there anyway, not draws,
    uniform writes or viewports of its own; the state kept and put back is the batch's, once."""
    from dentdemo.bench.run import gl_calls_per_batch

    calls = gl_calls_per_batch([1024])
    assert calls[1024, 64] <= 200, calls
    assert calls[1024, 64] - calls[1024, 1] <= 16, calls
