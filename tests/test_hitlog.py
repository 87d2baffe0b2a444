"""The hit log (model/hitlog.py, app/hitlog.py, api_hitlog.py): a run's carves as records that
carve the same maps again, bit for bit, with no physics. The oracle is the run itself: the maps
it carved live are compared with the maps a fresh scene gets from its log."""

from __future__ import annotations

import math
import struct
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cli_helpers import dentdemo
from dentdemo.model import hitlog
from dentdemo.model.hitlog import Body, Event, Groove, Hit, HitLogError
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]
BALL_DROP = ROOT / "assets" / "scenes" / "ball_drop.toml"


def _maps(sim) -> dict[str, tuple[bytes, bytes]]:
    return {
        body_id: (sim.gl.read(body.maps.height).tobytes(), sim.gl.read(body.maps.normal).tobytes())
        for body_id, body in sorted(sim.bodies.items())
    }


def _sim(gl):
    from dentdemo.app.simulation import Simulation

    lib = load_materials()
    return Simulation(gl, load_scene(BALL_DROP, lib), lib)


def _steps(sim, n: int) -> None:
    for _ in range(n):
        sim.step()


def _live_run(gl):
    """ball_drop with every kind of record: hits, balls added while running, an undo, a repair,
    a new depth bound (a materials reload), a reset and hits after it."""
    from dentdemo.app.hitlog import HitRecorder

    sim = _sim(gl)
    recorder = HitRecorder()
    recorder.attach(sim)
    _steps(sim, 60)
    sim.drop_ball((0.05, 0.3, 0.02), velocity=(0.0, -4.0, 0.0), radius=0.03)
    sim.drop_ball((-0.2, 0.25, 0.3), velocity=(0.5, -3.0, 0.0), radius=0.02, material="lead")
    _steps(sim, 40)
    assert sim.undo()
    _steps(sim, 20)
    hit_ids = [r.id for r in recorder.records if isinstance(r, Body)]
    sim.repair(hit_ids[0])
    lib = sim.materials
    steel = lib.materials["steel"]
    sim.set_materials(
        replace(lib, materials={**lib.materials, "steel": replace(steel, max_dent_depth=0.0004)})
    )
    _steps(sim, 40)
    live_before_reset = _maps(sim)
    sim.reset()
    _steps(sim, 30)
    sim.apply_queued()
    return sim, recorder, live_before_reset


@pytest.mark.parametrize("form", ["binary", "json lines"])
@pytest.mark.slow
def test_a_replayed_log_carves_the_live_maps_bit_for_bit(gl, form):
    from dentdemo.app.hitlog import replay

    live, recorder, _ = _live_run(gl)
    try:
        kinds = {
            type(r).__name__ if isinstance(r, Body | Hit) else r.kind for r in recorder.records
        }
        assert {"Body", "Hit", "undo", "repair", "depth_bound", "reset"} <= kinds
        assert any(isinstance(r, Body) and r.spec["added"] for r in recorder.records)
        data = (
            hitlog.to_bytes(recorder.records)
            if form == "binary"
            else hitlog.to_lines(recorder.records).encode()
        )
        records = hitlog.parse(data, "log")
        assert records == recorder.records
        copy = _sim(gl)
        try:
            assert replay(copy, records) == sum(isinstance(r, Hit) for r in records)
            assert copy.bodies.keys() == live.bodies.keys()
            want, got = _maps(live), _maps(copy)
            changed = [k for k in want if want[k] != got[k]]
            assert not changed
            # and the maps did change: the log is not a no-op
            fresh = _sim(gl)
            assert any(_maps(fresh)[k] != want[k] for k in want)
            fresh.close()
        finally:
            copy.close()
    finally:
        live.close()


@pytest.mark.slow
def test_replay_stops_where_the_log_stops_before_a_reset(gl):
    """The records up to the reset give the maps the live run had just before it."""
    from dentdemo.app.hitlog import replay

    live, recorder, before_reset = _live_run(gl)
    live.close()
    cut = next(i for i, r in enumerate(recorder.records) if getattr(r, "kind", "") == "reset")
    copy = _sim(gl)
    try:
        replay(copy, recorder.records[:cut])
        assert _maps(copy) == before_reset
    finally:
        copy.close()


@pytest.mark.slow
def test_the_binary_log_of_ball_drop_takes_under_200_bytes_a_hit(gl):
    from dentdemo.app.hitlog import HitRecorder

    sim = _sim(gl)
    recorder = HitRecorder()
    recorder.attach(sim)
    _steps(sim, 240)
    sim.apply_queued()
    sim.close()
    assert recorder.hits >= 20
    size = len(hitlog.to_bytes(recorder.records))
    assert size / recorder.hits < 200, (size, recorder.hits)


def _bits(value: float) -> bytes:
    return struct.pack("<d", value)


AWKWARD = (-0.0, 5e-324, math.pi, -1e300, 0.1 + 0.2)


def _records() -> list:
    rot = (math.cos(0.3), 0.0, math.sin(0.3), 0.0)
    matrix = tuple(float(x) for x in np.arange(12) * 0.37 - 2.0)
    return [
        Body(3, 0, "plate", {"added": False, "map_size": 512, "max_dent_depth": 0.01}),
        Body(
            3,
            1,
            "ball_7",
            {
                "added": True,
                "map_size": 64,
                "max_dent_depth": 0.02,
                "shape": {"kind": "sphere", "radius": 0.03},
            },
        ),
        Hit(
            3,
            0,
            0,
            1,
            (*AWKWARD[:3], 1.0, 0.0, 0.0, 0.0),
            (1.0, 2.0, 3.0, *rot),
            AWKWARD[2:],
            (-0.0, -1.0, -0.0),
            0.0,
            1e-3,
        ),
        Hit(
            3,
            0,
            1,
            0,
            matrix,
            (0.5, 0.25, -0.0, *rot),
            (1.0, 2.0, 3.0),
            (0.0, 0.0, 2.5),
            AWKWARD[4],
            0.0,
        ),
        Event(4, "undo"),
        Event(5, "depth_bound", 1, 0.004),
        Hit(
            9, 1, 1, 0, (0.0, 0.0, 0.0, *rot), matrix, (1.0, 2.0, 3.0), (0.0, 1.0, 0.0), 2e-3, 3e-3
        ),
        Event(9, "repair", 0),
        Event(10, "reset"),
        Groove(
            11,
            2,
            0,
            0.01,
            0.015,
            (),
            matrix,
            matrix[::-1],
            (0.1, 0.0, -0.0),
            (0.0, -1.0, 0.0),
            AWKWARD[1],
        ),
        Groove(
            11,
            2,
            1,
            0.0,
            0.0,
            tuple(np.linspace(-0.1, 0.1, 48)),
            matrix,
            matrix,
            (0.0, 0.0, 0.0),
            (0.0, -1.0, 0.0),
            2e-5,
        ),
    ]


@pytest.mark.parametrize("form", ["binary", "json lines"])
def test_records_come_back_bit_for_bit(form):
    records = _records()
    data = hitlog.to_bytes(records) if form == "binary" else hitlog.to_lines(records).encode()
    back = hitlog.parse(data, "log")
    assert back == records
    for a, b in zip(records, back, strict=True):
        if isinstance(a, Hit | Groove):
            for x, y in zip(hitlog._numbers(a), hitlog._numbers(b), strict=True):
                assert _bits(x) == _bits(y)  # -0.0 stays -0.0, subnormals stay


def test_a_hit_is_182_bytes_less_what_is_exactly_identity_or_zero():
    """6 vectors of float64 (3 + 4 + 3 + 4 + 3 + 3 numbers) and 2 depths, 6 bytes of kind,
    flags and ids; an identity quaternion (32 bytes) and a zero depth (8) are left out; the
    first hit of a batch follows a batch record (kind and frame, 5 bytes)."""
    rot = (0.6, 0.0, 0.8, 0.0)
    full = Hit(0, 0, 0, 1, (0, 0, 0, *rot), (0, 0, 0, *rot), (0, 0, 0), (0, -1, 0), 1e-3, 2e-3)
    lean = replace(full, target_pose=(0, 0, 0, 1.0, 0.0, 0.0, 0.0), tool_depth=0.0)
    encoder = hitlog.Encoder()
    assert len(encoder.encode(full)) == 5 + 6 + 22 * 8 == 5 + 182
    assert len(encoder.encode(full)) == 182
    assert len(encoder.encode(lean)) == 182 - 32 - 8


def _valid_binary() -> bytes:
    return hitlog.to_bytes(_records())


def _lines(*mutate) -> bytes:
    lines = hitlog.to_lines(_records()).splitlines()
    for index, old, new in mutate:
        assert old in lines[index]
        lines[index] = lines[index].replace(old, new)
    return ("\n".join(lines) + "\n").encode()


BAD = {
    "truncated": (_valid_binary()[:-3], "record at offset"),
    "cut at a record": (_valid_binary()[:-5], "no end record"),
    "cut at a line": (_lines()[: _lines().rindex(b"{")], "no end line"),
    "wrong version": (
        _valid_binary()[:4] + struct.pack("<H", 99) + _valid_binary()[6:],
        "version 99",
    ),
    "not a log": (b"\xff\xfe garbage", "UTF-8"),
    "not json": (b"hello\n", "line 1"),
    "non-finite": (_lines((2, '"target_depth": 0.0', '"target_depth": NaN')), "line 3"),
    "unknown body": (_lines((3, '"tool": 0', '"tool": 5')), "line 4: tool 5"),
    "frames go back": (_lines((4, '"frame": 4', '"frame": 1')), "line 5: frame 1"),
    "batch split": (_lines((6, '"batch": 1', '"batch": 0')), "line 7: batch 0"),
    "not unit": (_lines((2, "1.0, 2.0, 3.0, 0.955", "1.0, 2.0, 3.0, 1.955")), "line 3"),
    "missing key": (_lines((2, '"point"', '"pont"')), "line 3: missing key 'point'"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_log_is_one_line_naming_the_record(case):
    data, expected = BAD[case]
    with pytest.raises(HitLogError) as caught:
        hitlog.parse(data, "h.jsonl")
    message = str(caught.value)
    assert "\n" not in message and message.startswith("h.jsonl:")
    assert expected in message, message


@pytest.mark.slow
def test_replay_of_a_log_naming_a_body_the_scene_lacks_carves_nothing(gl, tmp_path):
    """Found in the log's body records before any batch: the hits before it are not carved."""
    from dentdemo.app.hitlog import HitRecorder

    sim = _sim(gl)
    recorder = HitRecorder()
    recorder.attach(sim)
    _steps(sim, 120)
    sim.close()
    assert recorder.hits > 0
    records = list(recorder.records)
    last = max(i for i, r in enumerate(records) if isinstance(r, Body))
    records[last] = replace(records[last], id="no_such_body")
    log = tmp_path / "h.ddhl"
    log.write_bytes(hitlog.to_bytes(records))
    out = tmp_path / "maps"
    result = dentdemo("replay", "--hit-log", log, "--maps-dir", out)
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "no_such_body" in lines[0] and "offset" in lines[0], lines
    assert not out.exists()


@pytest.mark.slow
def test_render_then_replay_gives_byte_identical_maps(tmp_path):
    """The issue's check, by the commands: render --hit-log, then replay, same .npy bytes."""
    log = tmp_path / "h.ddhl"
    a, b = tmp_path / "A", tmp_path / "B"
    run = dentdemo(
        "render", "--frames", 150, "--size", "64x36", "--out", tmp_path / "r.png",
        "--maps-dir", a, "--hit-log", log,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    again = dentdemo("replay", "--hit-log", log, "--maps-dir", b)
    assert again.returncode == 0, again.stderr
    names = sorted(p.name for p in a.iterdir())
    assert names and names == sorted(p.name for p in b.iterdir())
    assert any(np.load(a / n).min() < 0 for n in names if n.endswith(".npy"))
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


def test_a_hit_log_needs_a_known_suffix_before_any_work(tmp_path):
    result = dentdemo("render", "--frames", 1, "--out", tmp_path / "r.png", "--hit-log",
                      tmp_path / "h.txt")  # fmt: skip
    assert result.returncode != 0
    assert "--hit-log" in result.stderr and ".ddhl" in result.stderr
    assert not (tmp_path / "r.png").exists()


def test_a_host_carver_logs_its_presses_and_replay_repeats_them(gl):
    """The library API: Carver.log_to hands each press_many, undo and repair to a callback;
    dentdemo.replay carves the records onto another pair of surfaces, bit for bit."""
    import dentdemo

    ctx = gl.ctx

    def pair():
        plate = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Plate(0.4)), 256)
        ball = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Sphere(0.03)), 64)
        return plate, ball

    def at(x: float, z: float, scale: float = 1.0) -> np.ndarray:
        m = np.diag([scale, scale, scale, 1.0])
        m[:3, 3] = (x, 0.03 * scale, z)
        return m

    plate, ball = pair()
    other_plate, other_ball = pair()
    records: list = []
    carver = dentdemo.Carver(ctx)
    carver.log_to(records.append, {"plate": plate, "ball": ball})
    ball.model = at(0.05, 0.0)
    carver.press(plate, ball, dentdemo.Contact((0.05, 0.0, 0.0), (0, -1, 0)), 0.002, 0.001)
    ball.model = at(-0.1, 0.08, 1.5)  # scaled: the pose is logged as a matrix
    carver.press_many([(plate, ball, dentdemo.Contact((-0.1, 0.0, 0.08), (0.3, -1, 0)), 0.003)])
    ball.model = at(0.1, -0.1)
    carver.press(plate, ball, dentdemo.Contact((0.1, 0.0, -0.1), (0, -1, 0)), 0.004, 0.002)
    assert carver.undo()
    carver.repair(ball)
    ball.model = at(0.0, 0.1)
    carver.press(plate, ball, dentdemo.Contact((0.0, 0.0, 0.1), (0, -2, 0)), 0.001, 0.001)
    carver.log_to(None)
    assert [type(r).__name__ for r in records].count("Hit") == 4
    replayer = dentdemo.Carver(ctx)
    data = dentdemo.hitlog.to_bytes(records)
    assert dentdemo.replay(data, {"plate": other_plate, "ball": other_ball}, replayer) == 4
    assert np.array_equal(other_ball.model, np.eye(4))  # put back
    for mine, theirs in ((plate, other_plate), (ball, other_ball)):
        assert mine.heights().tobytes() == theirs.heights().tobytes()
        assert gl.read(mine.normal).tobytes() == gl.read(theirs.normal).tobytes()
    assert plate.heights().min() < -0.0009
    with pytest.raises(ValueError, match="no surface named 'ball'"):
        dentdemo.replay(records, {"plate": other_plate}, replayer)
    with pytest.raises(ValueError, match="has no name"):
        carver.log_to(records.append, {"plate": plate})
        carver.press(plate, ball, dentdemo.Contact((0.0, 0.0, 0.1), (0, -1, 0)), 0.001)
    for s in (plate, ball, other_plate, other_ball):
        s.release()
    carver.release()
    replayer.release()


@pytest.mark.slow
def test_the_replication_example_ends_with_equal_maps(tmp_path):
    """examples/replicate.py: a sender process simulates and streams records through a pipe,
    a receiver process only carves them; the sender compares both sides' map files."""
    import subprocess
    import sys

    result = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "replicate.py"), "--frames", "120",
         "--out-dir", str(tmp_path)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "equal the sender's, byte for byte" in result.stdout
    sender = sorted((tmp_path / "sender").iterdir())
    assert sender and any(np.load(p).min() < 0 for p in sender if p.suffix == ".npy")


@pytest.mark.slow
def test_the_demo_writes_its_hit_log_when_it_ends(tmp_path):
    """Without a display the demo renders headless; --hit-log is written there too."""
    import os

    log = tmp_path / "d.jsonl"
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    run = dentdemo("demo", "--exit-after", 2, "--screenshot", tmp_path / "s.png",
                   "--size", "64x36", "--hit-log", log, env=env)  # fmt: skip
    assert run.returncode == 0, run.stderr
    records = hitlog.parse(log.read_bytes(), str(log))
    assert sum(isinstance(r, Hit) for r in records) > 0


def test_a_scraped_scene_replays_its_grooves_bit_for_bit(gl):
    """Scratches are records too (groove records: the swept tool, both poses, the depth):
    scrape.toml's skidding balls (capsules) and sliding crate (a box's hull) replay to the
    live maps."""
    from dentdemo.app.hitlog import HitRecorder, replay
    from dentdemo.app.simulation import Simulation

    lib = load_materials()
    scene = load_scene(ROOT / "assets" / "scenes" / "scrape.toml", lib)
    live = Simulation(gl, scene, lib)
    recorder = HitRecorder()
    recorder.attach(live)
    _steps(live, 150)
    live.apply_queued()
    grooves = [r for r in recorder.records if isinstance(r, Groove)]
    assert any(g.points for g in grooves) and any(not g.points for g in grooves)
    want = _maps(live)
    live.close()
    records = hitlog.parse(hitlog.to_bytes(recorder.records), "log")
    copy = Simulation(gl, load_scene(ROOT / "assets" / "scenes" / "scrape.toml", lib), lib)
    try:
        replay(copy, records)
        got = _maps(copy)
        assert [k for k in want if want[k] != got[k]] == []
        fresh = Simulation(gl, load_scene(ROOT / "assets" / "scenes" / "scrape.toml", lib), lib)
        assert _maps(fresh)["plate"] != want["plate"]  # the plate was scratched
        fresh.close()
    finally:
        copy.close()


@pytest.mark.parametrize("chunk", [1, 7, 183, 1 << 20])
def test_a_stream_fed_in_any_pieces_gives_the_whole_files_records(chunk):
    """The streaming decoder, fed a log cut anywhere (mid-header, mid-record), gives the records
    and places `parse` gives the whole file, and sees its end record."""
    data = hitlog.to_bytes(_records())
    records, places = hitlog.parse_placed(data, "s")
    decoder = hitlog.Decoder("s")
    got = []
    for start in range(0, len(data), chunk):
        got += decoder.feed(data[start : start + chunk])
    assert decoder.ended
    assert [r for _, r in got] == records and [at for at, _ in got] == places
