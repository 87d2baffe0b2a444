"""Undo and repair (carve/undo.py): undo puts both bodies' heights and normals back bit for bit,
hit after hit, from GPU copies made before each carve (no readback); the log keeps its stated
depth and byte budget, dropping the oldest; repair gives exactly a fresh body's maps. The maps
the tests compare with are read back by the tests themselves, before each hit."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import moderngl
import numpy as np
import pytest

import dentdemo
from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import Carver
from dentdemo.carve.undo import (
    UNDO_BYTES,
    UNDO_DEPTH,
    UndoLog,
    chart_boxes,
    job_rects,
    merged_rects,
    packed,
    size_class,
)
from dentdemo.mesh.shapes import shape_mesh
from dentdemo.model.shapes import Plane
from gl_helpers import raw_gl_calls

SIDE = 0.4  # plate side, m
R = 0.05  # ball radius, m
PLATE = dentdemo.shape_mesh(dentdemo.Plate(SIDE))
BALL = dentdemo.shape_mesh(dentdemo.Sphere(R))
BOX = dentdemo.shape_mesh(dentdemo.Box((0.2, 0.2, 0.2)))
DOWN = (0.0, -1.0, 0.0)
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def scene(gl):
    """A 128^2 plate, a 64^2 ball and a Carver with the context's undo log (of the stated
    defaults), emptied first: surfaces that earlier tests left unreleased keep their part."""
    plate = dentdemo.DentableSurface(gl.ctx, PLATE, 128)
    ball = dentdemo.DentableSurface(gl.ctx, BALL, 64)
    carver = dentdemo.Carver(gl.ctx)
    log = carver._live().options.undo_log
    assert log is not None and (log.depth, log.budget) == (UNDO_DEPTH, UNDO_BYTES)
    log.clear()
    yield plate, ball, carver
    for thing in (carver, ball, plate):
        thing.release()


def _differences(now: list[tuple[bytes, bytes]], want: list[tuple[bytes, bytes]]) -> str:
    """Which maps of `now` differ from `want`, and in how many bytes (for failure messages)."""
    out = []
    for body, (got, expected) in enumerate(zip(now, want, strict=True)):
        for name, a, b in zip(("height", "normal"), got, expected, strict=True):
            if a != b:
                diff = np.frombuffer(a, np.uint8) != np.frombuffer(b, np.uint8)
                out.append(f"surface {body} {name}: {int(diff.sum())} bytes differ")
    return "; ".join(out) or "none differ"


def _maps(gl, *surfaces) -> list[tuple[bytes, bytes]]:
    """Each surface's height and normal map, read back as bytes (bit-exact comparisons)."""
    return [(s.heights().tobytes(), gl.read(s.normal).tobytes()) for s in surfaces]


def _press(carver, plate, ball, k: int) -> bool:
    """Press k: the ball 0.004-0.006 m into the plate at x = 0.01 k m (dents 2 cm across, so
    each overlaps the one before) and 1-2 mm into itself, always at its bottom."""
    x = -0.15 + 0.01 * k
    ball.model = np.eye(4)
    ball.model[:3, 3] = (x, R, 0.02 * (k % 3))
    depth = 0.004 + 0.002 * ((k * 7) % 5) / 4
    tool_depth = 0.001 + 0.001 * ((k * 3) % 4) / 3
    contact = dentdemo.Contact((x, 0.0, 0.02 * (k % 3)), DOWN)
    return carver.press(plate, ball, contact, depth, tool_depth)


@pytest.mark.parametrize("hits", [1, 2, 33])
def test_undo_takes_back_each_hit_bit_for_bit_on_both_bodies(gl, scene, hits):
    """Overlapping dents on the plate and on the ball's one spot, undone in reverse order: after
    each undo both bodies' maps equal, byte for byte, those read before that hit; one undo more
    is a no-op returning False. 33 hits: past the 32 the issue asks for."""
    plate, ball, carver = scene
    assert UNDO_DEPTH >= 33
    before = []
    for k in range(hits):
        before.append(_maps(gl, plate, ball))
        assert _press(carver, plate, ball, k)
    after = _maps(gl, plate, ball)
    dented = _differences(after, before[0])
    assert dented.count("differ") == 4, f"every map is dented: {dented}"
    for k in reversed(range(hits)):
        assert carver.undo()
        now = _maps(gl, plate, ball)
        assert now == before[k], f"undo of hit {k}: {_differences(now, before[k])}"
    assert not carver.undo()
    assert _maps(gl, plate, ball) == before[0]


def test_carvers_of_one_context_share_the_history(gl, scene):
    """A press by one Carver is undone by another of the same context (the history is the
    context's: surfaces and their snapshots belong to it)."""
    plate, ball, carver = scene
    before = _maps(gl, plate, ball)
    assert _press(carver, plate, ball, 0)
    other = dentdemo.Carver(gl.ctx)
    try:
        assert other.undo() and _maps(gl, plate, ball) == before
        assert not carver.undo()
    finally:
        other.release()


def test_undo_reads_nothing_back(gl, scene, monkeypatch):
    """The snapshot before a press and the undo are GPU copies: no texture or framebuffer is
    read while they run."""
    plate, ball, carver = scene

    def refuse(*args, **kwargs):
        raise AssertionError("read back during press or undo")

    with monkeypatch.context() as patch:
        for cls in (moderngl.Texture, moderngl.Framebuffer):
            patch.setattr(cls, "read", refuse)
            patch.setattr(cls, "read_into", refuse)
        assert _press(carver, plate, ball, 0)
        assert carver.undo()


def _changed(a: bytes, b: bytes, size: int, components: int, dtype) -> np.ndarray:
    """Where two map readbacks differ: bool [v, u]."""
    x = np.frombuffer(a, dtype).reshape(size, size, components)
    y = np.frombuffer(b, dtype).reshape(size, size, components)
    return (x != y).any(axis=2)


def _assert_written_inside(before, after, rects, size: int) -> None:
    """The press changed some heights and some normals (readbacks `before`, `after` of one
    size x size map), and every texel it changed lies in one of `rects` (x, y, w, h)."""
    inside = np.zeros((size, size), bool)
    for x, y, w, h in rects:
        inside[y : y + h, x : x + w] = True
    for i, dtype, comps in ((0, np.float32, 1), (1, np.uint8, 4)):
        changed = _changed(before[i], after[i], size, comps, dtype)
        assert changed.any()
        assert not (changed & ~inside).any(), (
            f"{int((changed & ~inside).sum())} texels written outside the snapshot"
        )


def test_snapshot_rectangles_hold_every_texel_a_hit_writes(gl):
    """A ball on a box's edge and corner dents several charts of its atlas: every texel whose
    height or normal the press changed lies in the rectangles snapshotted for it, and undo
    restores the box exactly."""
    box = dentdemo.DentableSurface(gl.ctx, BOX, 256)
    ball = dentdemo.DentableSurface(gl.ctx, BALL, 64)
    carver = dentdemo.Carver(gl.ctx)
    log = _logged(carver, UndoLog(carver._live().gl))
    try:
        for point, direction in (
            ((0.1, 0.1, 0.0), (-1.0, -1.0, 0.0)),  # edge: two faces
            ((0.1, 0.1, 0.1), (-1.0, -1.0, -1.0)),  # corner: three faces
        ):
            d = np.array(direction) / np.linalg.norm(direction)
            ball.model = np.eye(4)
            ball.model[:3, 3] = np.array(point) - d * R
            (before,) = _maps(gl, box)
            assert carver.press(box, ball, dentdemo.Contact(point, d), 0.005)
            (after,) = _maps(gl, box)
            rects = [snap.rect for snap in log.entries[-1] if snap.maps is box._live("")]
            _assert_written_inside(before, after, rects, 256)
            assert log.undo() and _maps(gl, box) == [before]
    finally:
        log.release()
        for thing in (carver, ball, box):
            thing.release()


def test_merged_rects_keep_far_boxes_apart():
    """Boxes (x0, y0, x1, y1), texels: two overlapping ones near the origin make one rectangle,
    their union (0, 0)-(20, 12); one 88 texels off stays its own; an L of two boxes that no
    empty row or column separates is one rectangle, their bounding box; boxes 7 texels apart
    (under the 8-texel gap) merge, 8 apart do not."""
    boxes = np.array([[0, 0, 10, 10], [100, 100, 110, 120], [5, 5, 20, 12]])
    assert sorted(merged_rects(boxes)) == [(0, 0, 20, 12), (100, 100, 10, 20)]
    ell = np.array([[0, 0, 10, 40], [0, 30, 40, 40]])
    assert merged_rects(ell) == [(0, 0, 40, 40)]
    near = np.array([[0, 0, 10, 10], [17, 0, 27, 10]])
    assert merged_rects(near) == [(0, 0, 27, 10)]
    apart = np.array([[0, 0, 10, 10], [18, 0, 28, 10]])
    assert sorted(merged_rects(apart)) == [(0, 0, 10, 10), (18, 0, 10, 10)]
    # Split along v, then one band split along u: three rectangles.
    three = np.array([[0, 0, 10, 10], [50, 0, 60, 10], [0, 50, 60, 60]])
    assert sorted(merged_rects(three)) == [(0, 0, 10, 10), (0, 50, 60, 10), (50, 0, 10, 10)]
    assert merged_rects(np.zeros((0, 4), np.int64)) == []


def _logged(carver, log: UndoLog) -> UndoLog:
    """`log` in place of the context's for the public `carver` (its inner carver made anew:
    options are fixed at construction)."""
    inner = carver._live()
    carver._carver = Carver(inner.gl, replace(inner.options, undo_log=log))
    inner.release()
    return log


def _own_log(carver, depth: int, budget: int) -> UndoLog:
    return _logged(carver, UndoLog(carver._live().gl, depth=depth, budget=budget))


def _entry_bytes(entry) -> int:
    """Texture bytes of an entry worked out from its pair of textures (w h (4 + 4)), after
    checking the pair: every snapshot's rectangle lies inside it at its own place, none
    overlaps another, and each side is at most 1.5 times (past 16 texels) the extent the
    rectangles reach."""
    height, normal = entry.textures.height, entry.textures.normal
    w, h = height.size
    taken = np.zeros((h, w), dtype=np.int64)
    for snap in entry:
        (x, y), (rw, rh) = snap.at, snap.rect[2:]
        assert 0 <= x and x + rw <= w and 0 <= y and y + rh <= h
        taken[y : y + rh, x : x + rw] += 1
    assert taken.max() == 1  # disjoint
    reach_x, reach_y = (
        np.nonzero(taken.any(axis=0))[0][-1] + 1,
        np.nonzero(taken.any(axis=1))[0][-1] + 1,
    )
    assert w <= max(16, 1.5 * reach_x) and h <= max(16, 1.5 * reach_y)
    assert height.dtype == "f4" and height.components == 1
    assert normal.size == (w, h) and normal.dtype == "f1"
    assert normal.components == 4
    return w * h * 4 + w * h * 4


def test_size_classes_by_hand():
    """16 up to 16 texels, then the powers of two and 1.5 times them: the least that holds."""
    expected = {1: 16, 16: 16, 17: 24, 24: 24, 25: 32, 32: 32, 33: 48, 48: 48, 49: 64}
    expected |= {96: 96, 97: 128, 129: 192, 193: 256, 4000: 4096, 4096: 4096}
    assert {side: size_class(side) for side in expected} == expected


def _made_during(monkeypatch, kind: str, call) -> list:
    """The GL objects of `kind` ("texture", "framebuffer") moderngl made while `call` ran."""
    made: list = []
    real = getattr(moderngl.Context, kind)
    with monkeypatch.context() as patch:
        patch.setattr(moderngl.Context, kind, lambda *a, **k: made.append(a) or real(*a, **k))
        call()
    return made


def test_dropped_snapshots_textures_serve_the_next_entries(gl, scene, monkeypatch):
    """A log one entry deep: each press drops the last entry, and the same press again makes
    its snapshots in the pair of textures of the one dropped, making no texture; the cleared
    log keeps that pair idle (its bytes), and release deletes it too."""
    plate, ball, carver = scene
    log = _own_log(carver, 1, UNDO_BYTES)
    try:
        _press(carver, plate, ball, 0)
        first = log.entries[-1].textures
        made = _made_during(monkeypatch, "texture", lambda: _press(carver, plate, ball, 0))
        entry = log.entries[-1]
        assert entry.textures is first and not made
        assert len(log) == 1 and log.idle_bytes == 0 and log.bytes == _entry_bytes(entry)
        log.clear()
        assert log.bytes == 0 and log.idle_bytes == _entry_bytes(entry)
    finally:
        log.release()
    assert log.idle_bytes == 0 and not log._idle
    assert all(
        isinstance(texture.mglo, moderngl.mgl.InvalidObject)
        for texture in (first.height, first.normal)
    )  # deleted


def test_a_batchs_snapshots_share_one_pair_of_textures(gl, scene, monkeypatch):
    """A press dents both bodies: the snapshots of both maps go into one pair of textures, made
    once (two textures, where a pair a rectangle made four), and undo puts both back bit for
    bit."""
    plate, ball, carver = scene
    log = _own_log(carver, UNDO_DEPTH, UNDO_BYTES)
    try:
        before = _maps(gl, plate, ball)
        made = _made_during(monkeypatch, "texture", lambda: _press(carver, plate, ball, 1))
        (entry,) = log.entries
        assert {id(snap.maps) for snap in entry} == {id(plate._live("")), id(ball._live(""))}
        assert len(made) == 2  # one height and one normal texture for the whole batch
        _entry_bytes(entry)
        assert _maps(gl, plate, ball) != before
        assert carver.undo()
        assert _maps(gl, plate, ball) == before, _differences(_maps(gl, plate, ball), before)
    finally:
        log.release()


def test_packing_by_hand():
    """Shelves of the tallest first, about as wide as the square of the area: two 10 x 10 and
    a 5 x 20 (area 300, width 18) put the 5 x 20 at the origin, one 10 x 10 beside it and the
    other on a shelf above (20 high); no rectangles, nothing."""
    at, extent = packed([(10, 10), (10, 10), (5, 20)])
    assert at == [(5, 0), (0, 20), (0, 0)] and extent == (15, 30)
    assert packed([]) == ([], (0, 0))
    assert packed([(7, 3)]) == ([(0, 0)], (7, 3))


def test_a_snapshot_makes_no_framebuffer_and_undoes_bit_for_bit(gl, scene, monkeypatch):
    """A press recorded into a fresh log makes its snapshots' textures but no framebuffer (each
    copy attaches a snapshot texture to one of the log's two), and undo through them puts both
    bodies' maps back bit for bit."""
    plate, ball, carver = scene
    log = _own_log(carver, UNDO_DEPTH, UNDO_BYTES)
    try:
        before = _maps(gl, plate, ball)
        made = _made_during(monkeypatch, "framebuffer", lambda: _press(carver, plate, ball, 3))
        assert len(log) == 1 and log.entries[-1] and not made
        assert _maps(gl, plate, ball) != before
        assert carver.undo()
        assert _maps(gl, plate, ball) == before, _differences(_maps(gl, plate, ball), before)
    finally:
        log.release()


def test_each_snapshot_texture_is_attached_once_a_record_and_an_undo(gl, scene):
    """A press's entry holds four copies (each body's height and normal rectangle) into one
    pair of textures: recording it attaches each of the two textures once to the log's draw
    framebuffer, and undoing it once to its read framebuffer (the copies into or out of one
    texture run one after the other), not once a copy; undo still puts both maps back bit for
    bit."""
    plate, ball, carver = scene
    log = _own_log(carver, UNDO_DEPTH, UNDO_BYTES)
    try:
        before = _maps(gl, plate, ball)
        # (target, texture) of each glFramebufferTexture2D(target, attachment, kind, texture, 0)
        with raw_gl_calls("glFramebufferTexture2D") as calls:
            assert _press(carver, plate, ball, 1)
            (entry,) = log.entries
            recorded = [(args[0], args[3]) for _, args in calls]
            calls.clear()
            assert carver.undo()
        attached = [(args[0], args[3]) for _, args in calls]
        pair = {entry.textures.height.glo, entry.textures.normal.glo}
        assert len(list(entry)) == 2  # one rectangle a body: four copies
        assert sorted(texture for _, texture in recorded) == sorted(pair)
        assert {target for target, _ in recorded} == {0x8CA9}  # GL_DRAW_FRAMEBUFFER
        assert sorted(texture for _, texture in attached) == sorted(pair)
        assert {target for target, _ in attached} == {0x8CA8}  # GL_READ_FRAMEBUFFER
        assert _maps(gl, plate, ball) == before, _differences(_maps(gl, plate, ball), before)
    finally:
        log.release()


def test_depth_bound_drops_the_oldest(gl, scene):
    """A log 4 deep after 6 hits undoes the last 4 (back to the maps after hit 2) and then
    nothing: undo past the bound is a no-op returning False."""
    plate, ball, carver = scene
    log = _own_log(carver, 4, UNDO_BYTES)
    try:
        states = []
        for k in range(6):
            states.append(_maps(gl, plate, ball))
            _press(carver, plate, ball, k)
            assert len(log) == min(k + 1, 4)
        for _ in range(4):
            assert carver.undo()
        assert _maps(gl, plate, ball) == states[2]
        assert not carver.undo()
        assert _maps(gl, plate, ball) == states[2]
    finally:
        log.release()


def test_byte_budget_drops_the_oldest_and_is_kept(gl, scene):
    """The bytes each hit's snapshots take, from their rectangles (w h 8); a log whose budget
    holds only the last two hits keeps exactly those two and their bytes; a budget under one
    hit's snapshots empties the log and records nothing."""
    plate, ball, carver = scene
    log = _own_log(carver, UNDO_DEPTH, UNDO_BYTES)
    sizes = []
    for k in range(3):
        _press(carver, plate, ball, k)
        sizes.append(_entry_bytes(log.entries[-1]))
    assert log.bytes == sum(sizes)
    while carver.undo():
        pass
    log.release()
    budget = sizes[1] + sizes[2]
    assert sum(sizes) > budget  # the first cannot stay beside the other two
    log = _own_log(carver, UNDO_DEPTH, budget)
    try:
        states = []
        for k in range(3):
            states.append(_maps(gl, plate, ball))
            _press(carver, plate, ball, k)
            assert log.bytes <= budget
        assert [_entry_bytes(e) for e in log.entries] == sizes[1:]
        assert log.bytes == budget
        assert carver.undo() and carver.undo() and not carver.undo()
        assert _maps(gl, plate, ball) == states[1]
        log.budget = min(sizes) - 1
        with pytest.warns(dentdemo.errors.UndoWarning, match="over the undo budget"):
            _press(carver, plate, ball, 5)
        assert len(log) == 0 and log.bytes == 0 and not carver.undo()
    finally:
        log.release()


def test_a_call_over_the_budget_is_carved_unrecorded_and_the_history_kept(gl, scene):
    """A budget that holds each of two presses but not a third, larger one (issue 41, item 7;
    ee6049f emptied the whole history there, silently): the third is carved, not recorded, and
    one UndoWarning says so with the budget; the two before it stay, and two undos take them
    back: the ball (which the third press does not dent) byte for byte as before them, the plate
    as before them everywhere but the third dent's texels, which keep that dent."""
    plate, ball, carver = scene
    log = _own_log(carver, UNDO_DEPTH, UNDO_BYTES)
    try:
        start = _maps(gl, plate, ball)
        for k in range(2):
            assert _press(carver, plate, ball, k)
        log.budget = max(_entry_bytes(entry) for entry in log.entries)
        before_big = _maps(gl, plate, ball)
        ball.model = np.eye(4)
        ball.model[:3, 3] = (0.12, R, 0.1)
        with pytest.warns(dentdemo.errors.UndoWarning) as caught:
            assert carver.press(plate, ball, dentdemo.Contact((0.12, 0.0, 0.1), DOWN), 0.012)
        assert len(caught) == 1
        message = str(caught[0].message)
        assert "over the undo budget" in message and "cannot be undone" in message
        assert "the 2 calls before it stay" in message
        assert len(log) == 2 and log.unrecorded == 1
        after_big = _maps(gl, plate, ball)
        assert after_big[1] == before_big[1]  # the ball: no dent from the third press
        assert carver.undo() and carver.undo() and not carver.undo()
        now = _maps(gl, plate, ball)
        assert now[1] == start[1]
        for index, kind in ((0, np.float32), (1, np.uint8)):  # the plate's heights, normals
            old, big_now = (np.frombuffer(m[0][index], kind) for m in (before_big, after_big))
            got, want = (np.frombuffer(m[0][index], kind) for m in (now, start))
            big = big_now != old  # the third dent's texels
            assert big.any() and np.array_equal(got[~big], want[~big])
            assert np.array_equal(got[big], big_now[big])
    finally:
        log.release()


def test_repair_gives_a_fresh_surfaces_maps(gl, scene):
    """After hits, repair gives exactly the maps of a surface just made (heights 0, flat
    normals), and of one made from the same heights where the surface started from a bump."""
    plate, ball, carver = scene
    for k in range(3):
        _press(carver, plate, ball, k)
    carver.repair(plate)
    carver.repair(ball)
    fresh_plate = dentdemo.DentableSurface(gl.ctx, PLATE, 128)
    fresh_ball = dentdemo.DentableSurface(gl.ctx, BALL, 64)
    try:
        assert _maps(gl, plate, ball) == _maps(gl, fresh_plate, fresh_ball)
        c = (np.arange(128) + 0.5) / 128
        bumps = (0.002 * np.sin(2 * np.pi * 3 * c)[None, :] * np.ones((128, 1))).astype("f4")
        plate.set_heights(bumps)
        fresh_plate.set_heights(bumps)
        _press(carver, plate, ball, 0)
        assert _maps(gl, plate) != _maps(gl, fresh_plate)
        carver.repair(plate)
        assert _maps(gl, plate) == _maps(gl, fresh_plate)
    finally:
        fresh_plate.release()
        fresh_ball.release()


def test_undo_after_repair_restores_only_the_other_body(gl, scene):
    """Two hits, then the plate repaired: undo takes back the ball's dents hit by hit while the
    plate stays pristine; then nothing is left."""
    plate, ball, carver = scene
    fresh = _maps(gl, plate)
    states = []
    for k in range(2):
        states.append(_maps(gl, ball))
        _press(carver, plate, ball, k)
    carver.repair(plate)
    assert _maps(gl, plate) == fresh
    for k in (1, 0):
        assert carver.undo()
        assert _maps(gl, ball) == states[k] and _maps(gl, plate) == fresh
    assert not carver.undo()


@pytest.mark.slow
def test_controller_undo_repair_and_load(gl, tmp_path):
    """The sandbox through its controller: the first hit of the ball drop undone bit for bit on
    both bodies (the same log as the API); repair gives the scene's pristine maps; a loaded
    state has no undo history, and the panel line says so."""
    from dentdemo.app.controller import DemoController
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene

    lib = load_materials()
    app = DemoController(gl, load_scene(ROOT / "assets/scenes/ball_drop.toml", lib), lib, (64, 36))
    try:
        sim = app.sim
        pristine = {i: _raw(gl, b.maps) for i, b in sim.bodies.items() if b.spec.dentable}
        sim.carve_budget = 0  # the hit waits in the queue: the maps before it are read here
        while not sim.queue:
            sim.step()
        request = sim.queue[0]
        hit = request.impact
        names = [n for n in (hit.body_a, hit.body_b) if sim.bodies[n].spec.dentable]
        before = {n: _raw(gl, sim.bodies[n].maps) for n in names}
        assert names and all(before[n] == pristine[n] for n in names)
        assert sim.apply_queued(1) == 1
        assert all(_raw(gl, sim.bodies[n].maps) != before[n] for n in names)
        assert app.undo.undo() and "undid" in app.message
        assert all(_raw(gl, sim.bodies[n].maps) == before[n] for n in names)
        assert not app.undo.undo() and app.message == "nothing to undo"
        sim.queue.appendleft(request)  # the same hit again, then repaired
        sim.apply_queued(1)
        target = app.undo.repair_target()
        assert target in names and _raw(gl, sim.bodies[target].maps) != pristine[target]
        assert app.undo.repair(target) and app.message == f"repaired {target}"
        assert _raw(gl, sim.bodies[target].maps) == pristine[target]
        assert not app.undo.repair("no_such_body") and "no_such_body" in app.message
        assert app.state.save(tmp_path / "s"), app.message
        assert app.state.load(tmp_path / "s"), app.message
        assert "undo history is not saved" in app.message
        assert len(sim.undo_log) == 0 and not app.undo.undo()
    finally:
        app.close()


def _raw(gl, maps) -> tuple[bytes, bytes]:
    return gl.read(maps.height).tobytes(), gl.read(maps.normal).tobytes()


def triangle_boxes(mesh, triangles, size) -> np.ndarray:
    """Each triangle's texel bounding box grown by 2 (the gutter draw's texel and one for
    rounding), clamped to the map: rows (x0, y0, x1, y1), half-open; one triangle at a time from
    its corners' uv."""
    w, h = size
    rows = []
    for t in np.asarray(triangles).tolist():
        uv = mesh.uvs[mesh.indices[t]].astype(np.float64)
        x0 = min(max(math.floor(uv[:, 0].min() * w) - 2, 0), w)
        y0 = min(max(math.floor(uv[:, 1].min() * h) - 2, 0), h)
        x1 = min(max(math.ceil(uv[:, 0].max() * w) + 2, 0), w)
        y1 = min(max(math.ceil(uv[:, 1].max() * h) + 2, 0), h)
        if x1 > x0 and y1 > y0:
            rows.append((x0, y0, x1, y1))
    return np.array(rows, np.int64).reshape(-1, 4)


def test_triangle_charts_are_the_atlas_islands():
    """A ball's cube-sphere atlas has 6 charts (one per cube face), a box's 6, a plate's 1:
    each triangle's chart is the lowest triangle index of its island, and two triangles that
    share an edge (the same two vertices) share a chart; each chart is one connected island,
    found here by a breadth-first walk over shared edges."""
    for mesh, count in ((BALL, 6), (BOX, 6), (PLATE, 1)):
        charts = mesh.triangle_charts()
        tri = mesh.indices.tolist()
        by_edge: dict[tuple[int, int], list[int]] = {}
        for t, (a, b, c) in enumerate(tri):
            for e in ((a, b), (b, c), (c, a)):
                by_edge.setdefault((min(e), max(e)), []).append(t)
        seen = [-1] * len(tri)
        for start in range(len(tri)):
            if seen[start] >= 0:
                continue
            seen[start], queue = start, [start]
            while queue:
                t = queue.pop()
                a, b, c = tri[t]
                for e in ((a, b), (b, c), (c, a)):
                    for other in by_edge[(min(e), max(e))]:
                        if seen[other] < 0:
                            seen[other] = start
                            queue.append(other)
        assert charts.tolist() == seen
        assert len(set(seen)) == count


def test_chart_boxes_bound_each_charts_triangle_boxes():
    """`chart_boxes` of random triangle sets of a ball's and a box's atlas is, chart by chart,
    the bounding box of the triangles' texel boxes there (`triangle_boxes` above, one triangle at
    a time, grouped by `triangle_charts`); no triangles, no box."""
    rng = np.random.default_rng(7)
    for mesh, size in ((BALL, (64, 64)), (BOX, (256, 128))):
        charts = mesh.triangle_charts()
        for count in (1, 2, 17, len(mesh.indices)):
            which = rng.choice(len(mesh.indices), count, replace=False)
            want = []
            for chart in sorted(set(charts[which].tolist())):
                boxes = triangle_boxes(mesh, which[charts[which] == chart], size)
                if len(boxes):
                    want.append([*boxes[:, :2].min(axis=0), *boxes[:, 2:].max(axis=0)])
            assert chart_boxes(mesh, which, size) == [tuple(box) for box in want]
    assert chart_boxes(BALL, np.zeros(0, np.int64), (64, 64)) == []


def plate_uv_map(mesh) -> np.ndarray:
    """The affine map (3 x 2) from a flat mesh's local (x, z, 1) to its uv, fitted by least
    squares over its vertices (for meshes in the local y = 0 plane)."""
    p = mesh.positions.astype(np.float64)
    assert np.abs(p[:, 1]).max() == 0.0
    design = np.column_stack([p[:, 0], p[:, 2], np.ones(len(p))])
    fit, *_ = np.linalg.lstsq(design, mesh.uvs.astype(np.float64), rcond=None)
    assert np.abs(design @ fit - mesh.uvs).max() < 1e-6  # one affine map
    return fit


def view_texel_box(job, fit, size) -> tuple[int, int, int, int]:
    """The box (x0, y0, x1, y1, half-open) of a plate's texels whose centres lie in `job`'s view
    rectangle seen along the press straight down (right and up horizontal): the rectangle's
    corners dropped onto y = 0, through `fit`."""
    cam = job.camera
    assert np.allclose(cam.forward, DOWN)
    hx, hy = cam.half_extent
    uv = np.array(
        [
            [*(np.asarray(cam.eye) + a * hx * cam.right + b * hy * cam.up)[[0, 2]], 1.0] @ fit
            for a in (-1, 1)
            for b in (-1, 1)
        ]
    )
    w, h = size
    return (
        math.ceil(uv[:, 0].min() * w - 0.5),
        math.ceil(uv[:, 1].min() * h - 0.5),
        math.floor(uv[:, 0].max() * w - 0.5) + 1,
        math.floor(uv[:, 1].max() * h - 0.5) + 1,
    )


@pytest.mark.parametrize("spot", [(0.0, 0.0), (0.13, -0.07), (-0.2, 0.19)])
def test_a_one_chart_press_snapshots_what_merging_its_boxes_gives(gl, spot):
    """A ball pressed into a plate (one chart) and itself at its bottom (inside one face of its
    atlas): each map's rectangle is exactly the one that merging every triangle's box gives
    (`merged_rects(triangle_boxes(...))`, the rule the module states), here worked out from the
    jobs' triangle lists; on the plate (flat: one plane, one affine uv map), within the box of
    its texels in the camera's view rectangle, grown by the same two texels."""
    plate = dentdemo.DentableSurface(gl.ctx, PLATE, 128)
    ball = dentdemo.DentableSurface(gl.ctx, BALL, 64)
    carver = dentdemo.Carver(gl.ctx)
    try:
        x, z = spot
        ball.model = np.eye(4)
        ball.model[:3, 3] = (x, R, z)
        live = carver._live()
        jobs = live.plan(
            plate._body("target"),
            ball._body("tool"),
            ContactFrame(np.array([x, 0.0, z]), np.array(DOWN)),
            0.005,
            0.002,
        )
        assert len(jobs) == 2
        for job, (maps, rects) in zip(jobs, job_rects(jobs), strict=True):
            assert maps is job.target.maps
            boxes = triangle_boxes(job.target.gpu_mesh.mesh, job.camera.target_texels, maps.size)
            if job.target.gpu_mesh.mesh is not PLATE:
                assert rects == merged_rects(boxes) and len(rects) == 1
                continue
            # The plate's: between the view's texels grown by one (the gutter's reach) and by
            # three (two, and one for rounding at the view's edges), within the merged boxes.
            ((x, y, w, h),) = rects
            (merged,) = merged_rects(boxes)
            view = view_texel_box(job, plate_uv_map(PLATE), maps.size)
            for grow, holds in ((1, True), (3, False)):
                bx0, by0 = max(view[0] - grow, merged[0]), max(view[1] - grow, merged[1])
                bx1 = min(view[2] + grow, merged[0] + merged[2])
                by1 = min(view[3] + grow, merged[1] + merged[3])
                inside = x <= bx0 and y <= by0 and x + w >= bx1 and y + h >= by1
                within = x >= bx0 and y >= by0 and x + w <= bx1 and y + h <= by1
                assert inside if holds else within, (rects, view, merged, grow)
    finally:
        for thing in (carver, ball, plate):
            thing.release()


@pytest.mark.parametrize("corner", [False, True], ids=["edge", "corner"])
def test_a_press_across_charts_snapshots_what_merging_its_boxes_gives(gl, corner):
    """A ball pressed on a box's edge (two charts) or corner (three): the box's rectangles are
    exactly those that merging every triangle's box gives, as for one chart."""
    box = dentdemo.DentableSurface(gl.ctx, BOX, 256)
    ball = dentdemo.DentableSurface(gl.ctx, BALL, 64)
    carver = dentdemo.Carver(gl.ctx)
    try:
        point = np.array((0.1, 0.1, 0.1 if corner else 0.0))
        d = -point / np.linalg.norm(point)
        ball.model = np.eye(4)
        ball.model[:3, 3] = point - d * R
        jobs = carver._live().plan(
            box._body("target"), ball._body("tool"), ContactFrame(point, d), 0.005, 0.0
        )
        (job,) = jobs
        mesh = job.target.gpu_mesh.mesh
        assert len(set(mesh.triangle_charts()[job.camera.target_texels].tolist())) == 2 + corner
        ((maps, rects),) = job_rects(jobs)
        boxes = triangle_boxes(mesh, job.camera.target_texels, maps.size)
        assert sorted(rects) == sorted(merged_rects(boxes))
    finally:
        for thing in (carver, ball, box):
            thing.release()


@pytest.mark.parametrize("plate_tilt", [0.0, 25.0, 60.0])
@pytest.mark.parametrize("press_tilt", [0.0, 35.0])
def test_a_plates_snapshot_is_its_dent_not_its_triangles(gl, plate_tilt, press_tilt):
    """The ground (4 m, 128 triangles a 512^2 map spreads over 64 texels each), posed tilted
    by `plate_tilt` about x, dented by a ball pressed `press_tilt` off its normal: every texel
    whose height or normal changed lies in the snapshot, undo puts the map back bit for bit,
    and the snapshot stays near the dent. The bound: the ball's shadow along the press on the
    plane (the tool dents nowhere else: at most R / cos(tilt) from the contact), grown by the
    view's margin (two plate texels and a pixel, one more pixel where the view snaps to whole
    pixels; a pixel is a plate texel here, the ball's being finer; along the press, so also
    stretched by 1 / cos(tilt)), by the snapshot's two texels and by one for rounding. The
    triangles' boxes alone gave at least 64 texels a side."""
    size, ball_size, depth = 512, 64, 0.005
    ground = shape_mesh(Plane())
    plate = dentdemo.DentableSurface(gl.ctx, ground, size)
    ball = dentdemo.DentableSurface(gl.ctx, BALL, ball_size)
    carver = dentdemo.Carver(gl.ctx)
    log = _logged(carver, UndoLog(carver._live().gl))
    fit = plate_uv_map(ground)
    a, t = math.radians(plate_tilt), math.radians(press_tilt)
    rotation = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    plate.model = np.eye(4)
    plate.model[:3, :3], plate.model[:3, 3] = rotation, (0.3, -0.2, 0.1)
    normal, along = rotation @ (0.0, 1.0, 0.0), rotation @ (1.0, 0.0, 0.0)
    press = -(math.cos(t) * normal + math.sin(t) * along)
    texel = 4.0 / size  # plate metres a texel
    assert max(BALL.uv_scale()) / ball_size < texel  # the ball's texels are the finer
    try:
        for local in ((0.0, 0.0), (0.61, -0.37), (-1.23, 1.4)):
            point = plate.model[:3, :3] @ (local[0], 0.0, local[1]) + plate.model[:3, 3]
            ball.model = np.eye(4)
            ball.model[:3, 3] = point + R * normal  # touching the plane at `point`
            (before,) = _maps(gl, plate)
            assert carver.press(plate, ball, dentdemo.Contact(point, press), depth)
            (after,) = _maps(gl, plate)
            (snapshot,) = [snap for snap in log.entries[-1] if snap.maps is plate._live("")]
            _assert_written_inside(before, after, [snapshot.rect], size)
            x, y, w, h = snapshot.rect
            reach = (R + 4 * texel) / math.cos(t)  # metres from the contact, at most
            centre = np.array([local[0], local[1], 1.0]) @ fit * size
            limit = reach / texel + 2 + 1
            assert x >= centre[0] - limit and x + w <= centre[0] + limit, (x, w, centre, limit)
            assert y >= centre[1] - limit and y + h <= centre[1] + limit, (y, h, centre, limit)
            assert log.undo() and _maps(gl, plate) == [before]
    finally:
        log.release()
        for thing in (carver, ball, plate):
            thing.release()
