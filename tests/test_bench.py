"""The benchmark's JSON schema (no timing asserted) and the CPU reference path as a second
implementation of the carve."""

import json
import struct

import numpy as np
import pytest

from carve_helpers import heights, release, setup
from cli_helpers import dentdemo
from dentdemo.app.press import cap_error
from dentdemo.carve.carver import Carver
from dentdemo.carve.cpu_reference import CpuReference


def test_gl_call_count_counts_each_call_once_and_only_while_open(gl):
    """Three calls of three kinds (a moderngl method, a property write, a raw entry point)
    count three; nothing counts once the count is closed."""
    from dentdemo.bench.glcount import counting
    from dentdemo.gl.library import gl_library

    texture = gl.ctx.texture((4, 4), 1)
    with counting() as calls:
        calls.reset()
        texture.use(0)
        gl.ctx.viewport = (0, 0, 4, 4)
        gl_library().glFlush()
        assert calls.count == 3
        texture.filter = (0x2600, 0x2600)  # GL_NEAREST
        assert calls.count == 4
        # A uniform write made the way gl.shaders' writers make it counts once.
        prog = gl.ctx.program(
            vertex_shader="#version 330\nuniform float u_x;\n"
            "void main() { gl_Position = vec4(u_x); }",
            fragment_shader="#version 330\nout vec4 c;\nvoid main() { c = vec4(1.0); }",
        )
        calls.reset()
        prog["u_x"].write(struct.pack("f", 0.5))
        assert calls.count == 1
    texture.use(0)
    gl_library().glFlush()
    assert calls.count == 1
    prog.release()
    texture.release()


@pytest.mark.slow
def test_bench_tiny_json_schema(gl, tmp_path):
    out, plot = tmp_path / "bench.json", tmp_path / "bench.png"
    result = dentdemo(
        "bench", "--tiny", "--frames", "3", "--json", str(out), "--plot", str(plot), timeout=600
    )
    assert result.returncode == 0, result.stderr
    data = json.loads(out.read_text())
    assert {
        "schema",
        "mode",
        "machine",
        "press",
        "per_hit",
        "burst",
        "passes",
        "frames",
        "memory",
        "agreement",
    } <= set(data)
    assert {"renderer", "gl_version", "cores"} <= set(data["machine"])
    for row in data["per_hit"]:
        assert {"map_size", "gpu_ms", "cpu_ms", "cpu_over_gpu", "reps", "camera_pixels"} <= set(row)
        assert row["gpu_ms"] > 0 and row["cpu_ms"] > 0
        # Both directions' cameras: the plate's and the ball's, each a footprint, not a body.
        assert len(row["camera_pixels"]) == 2 and all(p > 0 for p in row["camera_pixels"])
    assert [r["map_size"] for r in data["per_hit"]] == [128, 256]
    # The bench's plate and ball are built-in (convex) shapes: pass 2 has nothing to do for
    # them (docs/carve.md, "Pass 2").
    assert {p["pass"] for p in data["passes"]} == {"peel", "gather", "normals"}
    # Bursts of 1, 4, 16 and 64 hits at every map size: batched, one by one and the CPU path.
    assert [(b["map_size"], b["hits"]) for b in data["burst"]] == [
        (size, hits) for size in (128, 256) for hits in (1, 4, 16, 64)
    ]
    for b in data["burst"]:
        ms = [b[k] for k in ("gpu_ms_per_hit", "serial_ms_per_hit")]
        assert all(v > 0 for v in ms)
        # The CPU path goes one hit at a time: it is measured on bursts of up to 16.
        assert (b["cpu_ms_per_hit"] is None) == (b["hits"] > 16)
        assert b["cpu_ms_per_hit"] is None or b["cpu_ms_per_hit"] > 0
        parts = b["plan_ms_per_hit"] + b["submit_ms_per_hit"] + b["wait_ms_per_hit"]
        assert 0 < parts
        # The main thread's CPU time of planning and submission: some, and no more than their
        # wall time (it cannot run longer than it waits; a millisecond for the clocks' grain).
        cpu = b["main_thread_ms_per_hit"] * b["hits"]
        assert 0 < cpu <= (b["plan_ms_per_hit"] + b["submit_ms_per_hit"]) * b["hits"] + 1.0
        # A batch's GL calls, counted in a process of their own: a burst makes some.
        assert isinstance(b["gl_calls_per_batch"], int) and b["gl_calls_per_batch"] > 0
    assert "batched ms/hit" in result.stdout
    assert [(d["plate_side_m"], d["map_size"]) for d in data["same_dent"]] == [
        (0.25, 128),
        (0.5, 256),
    ]
    assert all(d["gpu_ms"] > 0 for d in data["same_dent"])
    assert [frame["frames"] for frame in data["frames"]] == [3]  # --frames, not tiny's 4
    for frame in data["frames"]:
        assert {"bodies", "frame_ms", "physics_ms", "carve_ms", "render_ms"} <= set(frame)
        # The carve over all timed frames, and per hit carved in them: a median frame's carve
        # is at most the sum of the frames' (none is negative), and the ratio is the quotient.
        assert frame["hits"] >= 0 and frame["carve_ms_total"] >= frame["carve_ms"] >= 0
        if frame["hits"]:
            per_hit = frame["carve_ms_total"] / frame["hits"]
            assert frame["carve_ms_per_hit"] == pytest.approx(per_hit, rel=1e-12)
        else:
            assert frame["carve_ms_per_hit"] is None
    assert data["memory"]["bytes_per_texel"] == 9
    # The scratch atlas a default Carver allocates: two RGBA32F textures (16 bytes a pixel) and
    # a depth texture (4), at their own size.
    carver = Carver(gl)
    try:
        scratch = carver.scratch
        textures = (scratch.address, scratch.tool_depth, scratch.depth)
        allocated = sum(t.width * t.height * (16 if t.components == 4 else 4) for t in textures)
    finally:
        carver.release()
    assert data["memory"]["scratch_bytes"] == allocated
    assert data["agreement"]["max_abs_diff_m"] < 1e-5
    assert plot.stat().st_size > 0
    assert "GPU ms/hit" in result.stdout and data["machine"]["renderer"] in result.stdout


@pytest.mark.slow
def test_the_frame_table_times_planning_undo_and_proxies_inside_the_carve(gl):
    """The sandbox frame table's parts of a hit's carve: the time of every `Carver.plan_many`
    call the frames made, of every `UndoLog.record` and of every `Simulation._follow_dents`
    (the collision proxies' presses), each counted here by a second wrapper. Each is a part of
    the carve's own time, and they never overlap (the carve plans, snapshots, then presses the
    proxies while its gathers are drawn), so together they are at most the carve."""
    from dentdemo.bench import run as bench_run

    calls: dict[str, list] = {"plan_many": [], "record": [], "_follow_dents": []}
    make = bench_run._clock

    def counted(owner, name):  # noqa: ANN001, ANN202
        spent = make(owner, name)
        timed = getattr(owner, name)

        def count(*args):  # noqa: ANN002, ANN202
            calls[name].append(args)
            return timed(*args)

        setattr(owner, name, count)
        return spent

    bench_run._clock = counted
    try:
        (row,) = bench_run.frame_times(gl, [12], 45, size=(64, 48))
    finally:
        bench_run._clock = make
    hits = row["hits"]
    assert hits > 0
    assert sum(len(presses) for (presses,) in calls["plan_many"]) == hits  # one plan a hit
    # One snapshot a batch, of the hits the batch planned (an undo entry is one frame's queue).
    assert len(calls["record"]) == len(calls["plan_many"])
    assert sum(len(batch) for (batch,) in calls["record"]) == hits
    assert len(calls["_follow_dents"]) == hits  # both bodies' proxies of each hit, in one call
    parts = [row[f"{part}_ms_per_hit"] for part in ("plan", "undo", "proxies")]
    assert all(part > 0.0 for part in parts)
    assert sum(parts) <= row["carve_ms_per_hit"]


@pytest.mark.slow
def test_bench_window_measures_the_real_window(xvfb, tmp_path):
    """`bench --window` runs the interactive window (wall-clock stepping, panel on) per preset
    and body count: one row each, at the window's own 1280 x 720 framebuffer, the body count
    the scene file and the drop give, and frame statistics that agree with each other."""
    import os

    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene
    from dentdemo.resources import assets_dir

    out = tmp_path / "bench.json"
    env = {**os.environ, "DISPLAY": xvfb}
    result = dentdemo("bench", "--tiny", "--window", "--json", str(out), env=env, timeout=600)
    assert result.returncode == 0, result.stderr
    rows = json.loads(out.read_text())["window"]
    scene = load_scene(assets_dir() / "scenes" / "ball_drop.toml", load_materials())
    expected_bodies = max(8, len(scene.bodies))  # tiny mode drops balls up to 8 bodies
    assert [(r["quality"], r["bodies"]) for r in rows] == [("low", expected_bodies)]
    row = rows[0]
    assert row["size"] == [1280, 720] and row["frames"] == 10
    assert 0 < row["frame_ms_median"] <= row["frame_ms_p90"]
    # The mean frame (1000 / fps) lies between the fastest and the slowest: within a factor
    # of the median that a 10-frame run can stray by.
    assert row["frame_ms_median"] / 4 < 1000.0 / row["fps"] < row["frame_ms_p90"] * 4
    assert "real window 1280x720" in result.stdout


@pytest.mark.parametrize("offset,depth", [((0.0, 0.0), 0.01), ((0.21, -0.13), 0.004)])
@pytest.mark.slow
def test_cpu_reference_matches_the_gpu_path(gl, offset, depth):
    carver = Carver(gl)
    gpu = setup(gl, offset=offset, tool_map_size=256)
    cpu = setup(gl, offset=offset, tool_map_size=256)
    carver.carve(gpu.target, gpu.tool, gpu.contact, depth, depth / 5)
    CpuReference(gl, carver).carve(cpu.target, cpu.tool, cpu.contact, depth, depth / 5)
    for a, b in ((gpu.target, cpu.target), (gpu.tool, cpu.tool)):
        np.testing.assert_allclose(heights(gl, b), heights(gl, a), atol=1e-5, rtol=0)
        assert (
            np.abs(gl.read(a.maps.normal).astype(int) - gl.read(b.maps.normal).astype(int)).max()
            <= 2
        )
    # And both meet the spherical-cap oracle.
    assert cap_error(heights(gl, cpu.target), 1.0, offset, 0.05, depth)["rms_error_rel"] < 0.02
    carver.release()
    release(gpu)
    release(cpu)
