"""The public API works only where its objects' GL context is current in the calling thread
(issue 41, items 4 and 5). With another context current, every call raises ContextError before
any work: the other context's textures keep every byte, it has no GL error, it stays current,
and the objects' own context finds its maps as they were (and a later undo() there restores them
exactly). A call from a second thread, where no context is current, says so, naming the thread
rule. On ee6049f the first press returned True and wrote the other context's textures, and a
call from a thread raised `KeyError: 0`."""

from __future__ import annotations

import threading

import numpy as np
import pytest

import dentdemo
from dentdemo.errors import ContextError
from dentdemo.gl.context import create_headless, current_native
from dentdemo.gl.state import preserved

PLATE = dentdemo.shape_mesh(dentdemo.Plate(0.4))
BALL = dentdemo.shape_mesh(dentdemo.Sphere(0.05))
DOWN = dentdemo.Contact((0.0, 0.0, 0.0), (0.0, -1.0, 0.0))
SIDE = 64  # texels a side of every map here


def _pair(ctx) -> tuple[dentdemo.DentableSurface, dentdemo.DentableSurface]:
    """A plate and a ball resting on its top face at the origin."""
    plate = dentdemo.DentableSurface(ctx, PLATE, SIDE)
    ball = dentdemo.DentableSurface(ctx, BALL, SIDE)
    ball.model[1, 3] = 0.05
    return plate, ball


def _maps(gl, *surfaces) -> list[bytes]:
    """Each surface's heights and normals as bytes (read through `gl`, which must be current)."""
    return [b for s in surfaces for b in (s.heights().tobytes(), gl.read(s.normal).tobytes())]


def _calls(plate, ball, carver, where) -> dict:
    """Every public call that touches the GL context, by the name its error starts with."""
    return {
        "DentableSurface()": lambda: dentdemo.DentableSurface(plate._gl.ctx, PLATE, SIDE),
        "Carver()": lambda: dentdemo.Carver(plate._gl.ctx),
        "press()": lambda: carver.press(plate, ball, DOWN, 0.002, 0.001),
        "press_many()": lambda: carver.press_many([(plate, ball, DOWN, 0.003)]),
        "undo()": carver.undo,
        "prepare()": lambda: carver.prepare(plate, ball),
        "repair()": lambda: carver.repair(plate),
        "heights()": plate.heights,
        "set_heights()": lambda: plate.set_heights(np.full((SIDE, SIDE), -1e-3, np.float32)),
        "set_bump_map()": lambda: plate.set_bump_map(where / "missing.png", 0.001),
        "export_gltf()": lambda: dentdemo.export_gltf(where / "x.glb", [plate, ball]),
        "release()": plate.release,
    }


def _refused(calls: dict, fragment: str) -> None:
    """Every call raises one line of ContextError, starting with its name, holding `fragment`."""
    for name, call in calls.items():
        with pytest.raises(ContextError) as info:
            call()
        message = str(info.value)
        assert isinstance(info.value, RuntimeError)
        assert message.startswith(f"{name}: ") and fragment in message, (name, message)
        assert "\n" not in message


def test_no_call_writes_another_current_context(gl, tmp_path):
    a = create_headless()
    b = None
    try:
        plate, ball, carver = *_pair(a.ctx), dentdemo.Carver(a.ctx)
        flat = _maps(a, plate, ball)
        assert carver.press(plate, ball, DOWN, 0.004, 0.001)
        dented = _maps(a, plate, ball)
        assert dented != flat
        b = create_headless()  # current now, as a host's second window would be
        made_in_b = current_native()
        # B's own maps, one texture name after another: A's objects have the same names here.
        rng = np.random.default_rng(41)
        mine = [
            b.ctx.texture((SIDE, SIDE), 4, rng.integers(0, 255, SIDE * SIDE * 4, np.uint8))
            for _ in range(24)
        ]
        before = [t.read() for t in mine]
        _refused(_calls(plate, ball, carver, tmp_path), "another GL context is current")
        assert current_native() == made_in_b  # the host's current context is its own
        assert b.ctx.error == "GL_NO_ERROR"
        assert [t.read() for t in mine] == before
        assert not (tmp_path / "x.glb").exists()
        b.release()
        b = None
        a.make_current()
        assert _maps(a, plate, ball) == dented  # nothing written in A either
        assert carver.undo() and _maps(a, plate, ball) == flat
        assert a.ctx.error == "GL_NO_ERROR"
        for thing in (carver, ball, plate):
            thing.release()
    finally:
        if b is not None:
            b.release()
        a.release()
        gl.make_current()


@pytest.mark.parametrize("own_context", [False, True])
def test_a_call_from_another_thread_names_the_thread_rule(gl, tmp_path, own_context):
    """From a worker thread with no context current, or with one of its own current, every
    call is refused naming the thread rule; the maps are untouched."""
    plate, ball = _pair(gl.ctx)
    carver = dentdemo.Carver(gl.ctx)
    calls = _calls(plate, ball, carver, tmp_path)
    failures: dict[str, BaseException | None] = {}

    def worker() -> None:
        mine = create_headless() if own_context else None
        for name, call in {**calls, "dentdemo": lambda: preserved(gl.ctx).__enter__()}.items():
            try:
                call()
                failures[name] = None
            except BaseException as exc:  # noqa: BLE001 (each is checked below)
                failures[name] = exc
        if mine is not None:
            mine.release()

    thread = threading.Thread(target=worker, name="host-worker")
    thread.start()
    thread.join()
    state = "has another GL context current" if own_context else "no GL context is current in"
    for name, exc in failures.items():
        assert isinstance(exc, ContextError), (name, repr(exc))
        message = str(exc)
        assert message.startswith(f"{name}: ") and "thread 'host-worker'" in message
        assert state in message
        assert "call dentdemo from the thread where its GL context is current" in message
        assert "(thread 'MainThread' made it" in message
    assert len(failures) == len(calls) + 1
    # Nothing was done: this thread finds the maps flat, and carves as before.
    gl.make_current()
    assert not plate.heights().any()
    assert carver.press(plate, ball, DOWN, 0.004)
    assert plate.heights().min() < -0.003
    for thing in (carver, ball, plate):
        thing.release()


def test_objects_of_a_released_context_release_without_gl(gl):
    """Once a host releases a context (its objects go with it), releasing its surfaces and
    carver makes no GL call: with another context current, one with objects of the same names,
    those objects keep every byte and no GL error is left."""
    a = create_headless()
    try:
        plate, ball = _pair(a.ctx)
        carver = dentdemo.Carver(a.ctx)
        assert carver.press(plate, ball, DOWN, 0.004)
    finally:
        a.release()
    gl.make_current()
    mine = [gl.ctx.texture((SIDE, SIDE), 4, bytes([k]) * SIDE * SIDE * 4) for k in range(24)]
    before = [t.read() for t in mine]
    for thing in (carver, ball, plate):
        thing.release()
        thing.release()  # again: nothing
    assert [t.read() for t in mine] == before
    assert gl.ctx.error == "GL_NO_ERROR"
    for texture in mine:
        texture.release()
