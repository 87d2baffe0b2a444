"""The benchmark: per-hit cost against map size (GPU path and the paper's CPU path), the split by
pass, sandbox frame times against scene size, and the memory of the maps."""

from __future__ import annotations

import math
import multiprocessing
import os
import platform
import statistics
import time
from collections.abc import Callable
from functools import partial
from typing import TypedDict

import numpy as np

from dentdemo import interrupt
from dentdemo.app.press import make_setup, shape_from_args
from dentdemo.bench.glcount import counting
from dentdemo.bench.timing import PassTimer, interleaved_medians, median_ms
from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import (
    ATLAS_BYTES_PER_PIXEL,
    MAX_RESOLUTION,
    CarveBody,
    Carver,
    CarverOptions,
    Press,
    atlas_size,
)
from dentdemo.carve.cpu_reference import CpuReference
from dentdemo.gl.context import GLContext, create_headless
from dentdemo.progress import progress_bar
from dentdemo.version import VERSION

#: The press every per-hit measurement uses: a 5 cm ball 1 cm into a 1 m plate, the ball 2 mm.
PRESS = {"tool_radius_m": 0.05, "plate_side_m": 1.0, "depth_m": 0.01, "tool_depth_m": 0.002}
#: Tessellation of the bench's meshes (Shape.mesh detail): 2 as measured before carve v2.
DETAIL = 2
#: The same dent in texels on plates of growing size (plate side m, map side): the cost of a hit
#: must follow its footprint, not the map.
SAME_DENT = [(0.5, 512), (4.0, 4096)]


class WindowMode(TypedDict):
    presets: list[str]
    bodies: list[int]
    frames: int


class Mode(TypedDict):
    """What one bench mode measures: map sizes, repetitions, body counts, frames."""

    sizes: list[int]
    reps: int
    bodies: list[int]
    frames: int
    cpu_sizes: list[int]
    same_dent: list[tuple[float, int]]
    window: WindowMode


MODES: dict[str, Mode] = {
    "tiny": {
        "sizes": [128, 256],
        "reps": 2,
        "bodies": [8],
        "frames": 4,
        "cpu_sizes": [128, 256],
        "same_dent": [(0.25, 128), (0.5, 256)],
        "window": {"presets": ["low"], "bodies": [8], "frames": 10},
    },
    "quick": {
        "sizes": [256, 1024, 4096],
        "reps": 5,
        "bodies": [20, 100],
        "frames": 20,
        "cpu_sizes": [256, 1024, 4096],
        "same_dent": SAME_DENT,
        "window": {"presets": ["low", "medium", "high"], "bodies": [20, 100], "frames": 120},
    },
    "full": {
        "sizes": [256, 512, 1024, 2048, 4096],
        "reps": 15,
        "bodies": [20, 100, 500],
        "frames": 60,
        "cpu_sizes": [256, 512, 1024, 2048, 4096],
        "same_dent": SAME_DENT,
        "window": {"presets": ["low", "medium", "high"], "bodies": [20, 100], "frames": 240},
    },
}


def _press_setup(gl: GLContext, size: int, side: float = PRESS["plate_side_m"]):
    return make_setup(
        gl,
        shape_from_args("plate", [side], "target"),
        shape_from_args("sphere", [PRESS["tool_radius_m"]], "tool"),
        size,
        256,
        detail=DETAIL,
    )


def _press(setup) -> Press:
    return Press(setup.target, setup.tool, setup.contact, PRESS["depth_m"], PRESS["tool_depth_m"])


def same_dent(gl: GLContext, plates: list[tuple[float, int]], reps: int) -> list[dict]:
    """Median ms per press (both bodies) of the same dent, in metres and in texels, on plates
    whose maps grow with their side; the plates take turns within each repetition."""
    carver = Carver(gl)
    setups = [_press_setup(gl, size, side) for side, size in plates]
    presses = [_press(setup) for setup in setups]
    runs = [partial(carver.carve, *press) for press in presses]
    medians = interleaved_medians(runs, gl.ctx.finish, reps)
    rows = []
    for (side, size), press, ms in zip(plates, presses, medians, strict=True):
        jobs = carver.plan(*press)
        rows.append(
            {
                "plate_side_m": side,
                "map_size": size,
                "texel_m": side / size,
                "gpu_ms": ms,
                "camera_pixels": [job.camera.pixels for job in jobs],
            }
        )
    for setup in setups:
        _release(setup)
    carver.release()
    return rows


#: Hits in a burst: the bench's press at this many spots of the plate, carved together.
BURSTS = [1, 4, 16, 64]
#: The CPU path carves a burst one hit at a time, so its cost per hit does not depend on the
#: burst: it is measured up to this many hits (it is 10-40x the GPU path's, on a GPU host too).
CPU_BURST_MAX = 16


def _burst_presses(setup, hits: int) -> list[Press]:
    """The bench's press at `hits` spots on a grid over the plate's middle, each with the ball
    posed at first touch there (one ball body: its own dents overlap, as they would)."""
    side = math.ceil(math.sqrt(hits))
    spacing = 0.8 * PRESS["plate_side_m"] / max(side, 1)
    target, tool, contact, depth, tool_depth = _press(setup)
    presses = []
    for k in range(hits):
        offset = np.array(
            [(k % side - (side - 1) / 2) * spacing, 0.0, (k // side - (side - 1) / 2) * spacing]
        )
        model = np.array(tool.model, dtype=np.float64)
        model[:3, 3] += offset
        point = np.asarray(contact.point, dtype=np.float64) + offset
        moved = CarveBody(tool.gpu_mesh, tool.maps, model)
        presses.append(
            Press(target, moved, ContactFrame(point, contact.direction), depth, tool_depth)
        )
    return presses


def burst(
    gl: GLContext, sizes: list[int], cpu_sizes: list[int], reps: int, tick=lambda: None
) -> list[dict]:
    """ms per hit, amortised, of bursts of the bench's press: batched on the GPU (split into
    planning, submission and the wait for the GPU), the same hits one by one, and the CPU path
    one by one. Runs alternate within every repetition."""
    calls = gl_calls_per_batch(sizes)
    carver = Carver(gl)
    finish = gl.ctx.finish
    rows = []
    for size in sizes:
        setup = _press_setup(gl, size)
        reference = CpuReference(gl, carver) if size in cpu_sizes else None
        cpu_setup = _press_setup(gl, size) if reference is not None else None
        if reference is not None and cpu_setup is not None:
            for body in (cpu_setup.target, cpu_setup.tool):
                interrupt.check()
                reference.mirror(body)
        for hits in BURSTS:
            interrupt.check()
            presses = _burst_presses(setup, hits)
            # Each batched run's wall ms and its parts: planning, submission, the wait for the
            # GPU, and the main thread's CPU time of the first two.
            split: list[tuple[float, float, float, float, float]] = []

            def batched(presses=presses, split=split) -> None:
                start, cpu = time.perf_counter(), time.thread_time()
                planned = carver.plan_many(presses)
                planning = time.perf_counter()
                carver.carve_hits(planned)
                submitted = time.perf_counter()
                thread = time.thread_time() - cpu
                finish()
                done = time.perf_counter()
                parts = (done - start, planning - start, submitted - planning, done - submitted)
                split.append(tuple(x * 1e3 for x in (*parts, thread)))

            def serial(presses=presses) -> None:
                for press in presses:
                    carver.carve(*press)

            runs: list[Callable[[], None]] = [batched, serial]
            if reference is not None and cpu_setup is not None and hits <= CPU_BURST_MAX:
                cpu_presses = _burst_presses(cpu_setup, hits)

                def cpu(cpu_presses=cpu_presses, reference=reference) -> None:
                    for press in cpu_presses:
                        reference.carve(*press)

                runs.append(cpu)
            medians = interleaved_medians(runs, finish, reps)
            # The parts of the batched run whose wall time is the median (after the warm-ups):
            # parts of one run add up, and its thread's CPU time is no more than its wall time,
            # where medians taken part by part need not be.
            timed = sorted(split[len(split) - reps :])
            _, plan, submit, wait, thread = timed[(len(timed) - 1) // 2]
            row: dict[str, object] = {
                "hits": hits,
                "map_size": size,
                "gpu_ms_per_hit": medians[0] / hits,
                "serial_ms_per_hit": medians[1] / hits,
                "cpu_ms_per_hit": medians[2] / hits if len(medians) > 2 else None,
                "plan_ms_per_hit": plan / hits,
                "submit_ms_per_hit": submit / hits,
                "wait_ms_per_hit": wait / hits,
                # The main thread's CPU time of planning and submission (no waits): what the
                # interpreter and the driver's work on that thread cost, steadier than the wall
                # time on a loaded machine.
                "main_thread_ms_per_hit": thread / hits,
                "gl_calls_per_batch": calls.get((size, hits)),
            }
            rows.append(row)
        _release(setup)
        if cpu_setup is not None:
            _release(cpu_setup)
        tick()
    carver.release()
    return rows


def gl_calls_per_batch(sizes: list[int]) -> dict[tuple[int, int], int]:
    """GL calls (`bench.glcount`) of one batched burst of each size in BURSTS at each map size
    (planned and carved: `plan_many`, `carve_hits`), counted in a process of their own, whose
    context is made inside the count (the timed one is left as it is)."""
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        found = pool.apply(_count_bursts, (sizes,))
    return {(size, hits): count for size, hits, count in found}


def _count_bursts(sizes: list[int]) -> list[tuple[int, int, int]]:
    out = []
    with counting() as calls:
        gl = create_headless()
        carver = Carver(gl)
        for size in sizes:
            setup = _press_setup(gl, size)
            for hits in BURSTS:
                presses = _burst_presses(setup, hits)
                for _ in range(2):  # the first makes the vertex arrays, compiles the variants
                    calls.reset()
                    carver.carve_hits(carver.plan_many(presses))
                out.append((size, hits, calls.count))
            _release(setup)
        carver.release()
        gl.release()
    return out


def _release(setup) -> None:
    for body in (setup.target, setup.tool):
        body.maps.release()
        body.gpu_mesh.release()


def per_hit(
    gl: GLContext,
    sizes: list[int],
    cpu_sizes: list[int],
    reps: int,
    tick: Callable[[], object] = lambda: None,
) -> tuple[list, list, dict]:
    """Median ms per press (both bodies) for both paths, and the per-pass split."""
    carver = Carver(gl)
    rows, passes = [], []
    agreement = {"max_abs_diff_m": 0.0}
    finish = gl.ctx.finish
    for size in sizes:
        interrupt.check()
        gpu_setup = _press_setup(gl, size)
        press = _press(gpu_setup)
        gpu_ms, _ = median_ms(partial(carver.carve, *press), finish, reps)
        timer = PassTimer(gl.ctx)
        timed = Carver(gl, CarverOptions(pass_timer=timer))
        for _ in range(reps):
            interrupt.check()
            timed.carve(*press)
            timer.end_hit()
        for name, ms in timer.medians().items():
            passes.append({"map_size": size, "pass": name, "ms": ms, "gpu_timer": timer.gpu})
        pixels = [job.camera.pixels for job in timed.last_jobs]
        timed.release()
        row = {
            "map_size": size,
            "gpu_ms": gpu_ms,
            "reps": reps,
            # Collision-camera pixels of both directions: the plate dented, the ball dented.
            "camera_pixels": pixels,
        }
        if size in cpu_sizes:
            interrupt.check()  # each of these steps takes up to 0.4 s at 4096² on llvmpipe
            cpu_setup = _press_setup(gl, size)
            reference = CpuReference(gl, carver)
            for body in (cpu_setup.target, cpu_setup.tool):
                interrupt.check()
                reference.mirror(body)  # the CPU path's own copy, made once, outside the timing
            cpu_press = _press(cpu_setup)
            cpu_ms, _ = median_ms(partial(reference.carve, *cpu_press), finish, reps)
            row["cpu_ms"] = cpu_ms
            row["cpu_over_gpu"] = cpu_ms / gpu_ms if gpu_ms > 0 else None
            diff = np.abs(
                gl.read(gpu_setup.target.maps.height) - gl.read(cpu_setup.target.maps.height)
            ).max()
            agreement["max_abs_diff_m"] = max(agreement["max_abs_diff_m"], float(diff))
            _release(cpu_setup)
        rows.append(row)
        _release(gpu_setup)
        tick()
    carver.release()
    return rows, passes, agreement


def drop_balls(app, count: int) -> None:  # noqa: ANN001 - a DemoController
    """Balls of seeded random size and material dropped over ball_drop's plates until the scene
    has `count` bodies: the sandbox load every frame measurement uses."""
    rng = np.random.default_rng(count)
    names = ["steel", "brass", "copper", "lead", "clay", "rubber", "aluminium"]
    for i in range(max(0, count - len(app.sim.bodies))):
        pos = (rng.uniform(-0.5, 0.5), rng.uniform(0.15, 1.5), rng.uniform(-0.5, 0.5))
        app.sim.drop_ball(
            pos,
            material=names[i % len(names)],
            radius=float(rng.uniform(0.015, 0.04)),
            texels_per_metre=512,
        )


def _ball_drop():
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene
    from dentdemo.resources import assets_dir

    materials = load_materials()
    return load_scene(assets_dir() / "scenes" / "ball_drop.toml", materials), materials


def frame_times(
    gl: GLContext,
    body_counts: list[int],
    frames: int,
    size=(1280, 720),
    tick: Callable[[], object] = lambda: None,
    wear_scale: float = 0.0,
) -> list[dict]:
    """Sandbox frames through the frame loop (physics step, carves, render at `size`) with N
    bodies dropped on plates; each phase ends with glFinish so that its time is its own. Besides
    the medians a frame: the carve's ms over all the frames and per hit carved in them, and of
    that, per hit, the planning's (pass 1, `Carver.plan_many`, on the CPU), the undo
    snapshots' (`UndoLog.record`) and the collision proxies' presses (app/reshape.py,
    `Simulation._follow_dents`): the last two came after the release issue 20 measures against
    (b498167), which did neither, so a comparison with it can leave them out. `wear_scale`:
    the scene's physics wears (scratches, app/wear.py) at that scale."""
    out = []
    for count in body_counts:
        app, loop = _sandbox(gl, count, size, wear_scale)
        hits_before = app.sim.stats.hits
        planning = _clock(app.sim.carver, "plan_many")
        undo = _clock(app.sim.undo_log, "record")
        proxies = _clock(app.sim, "_follow_dents")
        timings = [loop.frame(measure=True) for _ in range(frames)]
        hits = app.sim.stats.hits - hits_before
        physics = [t.physics_ms for t in timings]
        carve = [t.carve_ms for t in timings]
        render = [t.render_ms for t in timings]
        total = [t.total_ms for t in timings]
        out.append(
            {
                "bodies": len(app.sim.bodies),
                "frames": frames,
                "size": list(size),
                "frame_ms": statistics.median(total),
                "physics_ms": statistics.median(physics),
                "carve_ms": statistics.median(carve),
                "render_ms": statistics.median(render),
                "hits": hits,
                "carve_ms_total": sum(carve),
                "carve_ms_per_hit": sum(carve) / hits if hits else None,
                "plan_ms_per_hit": planning[0] * 1e3 / hits if hits else None,
                "undo_ms_per_hit": undo[0] * 1e3 / hits if hits else None,
                "proxies_ms_per_hit": proxies[0] * 1e3 / hits if hits else None,
                "grooves": app.sim.wear.carved if app.sim.wear is not None else 0,
            }
        )
        app.close()
        tick()
    return out


def _clock(owner: object, name: str) -> list[float]:
    """Seconds of wall time `owner.name` (a method) takes from now on, summed in the list's one
    item: the instance's method wrapped, so every call the frames make through the instance is
    timed (the carve plans each batch with `Carver.plan_many`, snapshots it with
    `UndoLog.record` and presses the proxies with `Simulation._follow_dents`)."""
    spent = [0.0]
    method = getattr(owner, name)

    def timed(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202 - the method's own
        start = time.perf_counter()
        try:
            return method(*args, **kwargs)
        finally:
            spent[0] += time.perf_counter() - start

    setattr(owner, name, timed)
    return spent


#: Frames the window runs before its frames are timed (shader compiles, first carves).
WINDOW_WARMUP = 10


def window_frames(
    presets: list[str],
    body_counts: list[int],
    frames: int,
    size=(1280, 720),
    tick: Callable[[], object] = lambda: None,
) -> list[dict]:
    """The interactive demo as a person runs it: a real window with its panel, the simulation
    stepped by wall time, no glFinish between phases. Frames per wall-clock second by preset and
    body count, over `frames` frames after WINDOW_WARMUP."""
    from dentdemo.app.loop import FrameLoop
    from dentdemo.app.window import DemoWindow

    scene, materials = _ball_drop()
    out = []
    window = DemoWindow(scene, materials, size, presets[0])  # one window, as a person has it
    try:
        loop = FrameLoop(window.app, window, fixed_dt=False)
        for quality in presets:
            window.app.view.set_quality(quality)  # the panel's "quality"
            for count in body_counts:
                window.app.reset()
                drop_balls(window.app, count)
                for _ in range(WINDOW_WARMUP):
                    loop.frame()
                stamps = [time.perf_counter()]
                for _ in range(frames):
                    loop.frame()
                    stamps.append(time.perf_counter())
                ms = np.diff(stamps) * 1e3
                out.append(
                    {
                        "quality": quality,
                        "bodies": len(window.app.sim.bodies),
                        "frames": frames,
                        "size": list(window.size()),
                        "fps": frames / (stamps[-1] - stamps[0]),
                        "frame_ms_median": float(np.median(ms)),
                        "frame_ms_p90": float(np.percentile(ms, 90)),
                        "renderer": window.gl.renderer,
                    }
                )
                tick()
    finally:
        window.close()
    return out


def memory(gl: GLContext) -> dict:
    from dentdemo.carve.surface import BYTES_PER_TEXEL

    per_texel = BYTES_PER_TEXEL
    return {
        "bytes_per_texel": per_texel,
        "layout": "R32F height (4) + RGBA8 normal (4) + R8UI chart mask (1)",
        "map_bytes": {str(s): s * s * per_texel for s in (256, 512, 1024, 2048, 4096)},
        "scratch_bytes": math.prod(atlas_size(MAX_RESOLUTION)) * ATLAS_BYTES_PER_PIXEL,
    }


def _sandbox(gl: GLContext, count: int, size: tuple[int, int], wear_scale: float = 0.0):
    """The ball-drop sandbox with `count` bodies (its physics wearing at `wear_scale`) and its
    frame loop, headless at `size`."""
    from dataclasses import replace

    from dentdemo.app.controller import DemoController
    from dentdemo.app.loop import FrameLoop, ImageBackend

    scene, materials = _ball_drop()
    scene = replace(scene, physics=replace(scene.physics, wear_scale=wear_scale))
    app = DemoController(gl, scene, materials, size)
    drop_balls(app, count)
    return app, FrameLoop(app, ImageBackend(size, None), fixed_dt=True)


#: The scratch comparison's wear scale: scrape.toml's.
SCRATCH_WEAR_SCALE = 1e6


def scratch_frames(gl: GLContext, count: int, frames: int, size=(1280, 720)) -> dict:
    """The sandbox of `count` bodies without and with scratches (wear_scale
    SCRATCH_WEAR_SCALE), two of them in this process stepped frame by frame in turn, so that
    both see the same load: each one's median frame time, their ratio, and the grooves the
    one with scratches carved."""
    runs = [_sandbox(gl, count, size, scale) for scale in (0.0, SCRATCH_WEAR_SCALE)]
    times: list[list[float]] = [[], []]
    for _ in range(frames):
        for (_, loop), into in zip(runs, times, strict=True):
            into.append(loop.frame(measure=True).total_ms)
    wear = runs[1][0].sim.wear
    for app, _ in runs:
        app.close()
    without, with_ = statistics.median(times[0]), statistics.median(times[1])
    return {
        "bodies": count,
        "frames": frames,
        "wear_scale": SCRATCH_WEAR_SCALE,
        "frame_ms_without": without,
        "frame_ms_with": with_,
        "ratio": with_ / without,
        "grooves": wear.carved if wear is not None else 0,
    }


def run_bench(mode: str, window: bool = False, frames: int | None = None) -> dict:
    """The bench in `mode`; with `window`, the interactive window's frame rates too (a display
    is needed: the caller checks); `frames` replaces the mode's count of sandbox frames."""
    cfg = MODES[mode]
    win = cfg["window"]
    stages = 2 * len(cfg["sizes"]) + 2 + len(cfg["bodies"])
    if window:
        stages += len(win["presets"]) * len(win["bodies"])
    start = time.perf_counter()
    bar = progress_bar(stages, "stages")
    tick = bar.update if bar is not None else (lambda: None)
    # The window first: a GLX window context cannot be made current in a process that holds an
    # EGL context (X_GLXMakeCurrent: BadAccess), while the reverse order works.
    windows = None
    if window:
        windows = window_frames(win["presets"], win["bodies"], win["frames"], tick=tick)
    gl = create_headless()
    try:
        rows, passes, agreement = per_hit(gl, cfg["sizes"], cfg["cpu_sizes"], cfg["reps"], tick)
        bursts = burst(gl, cfg["sizes"], cfg["cpu_sizes"], cfg["reps"], tick)
        same = same_dent(gl, cfg["same_dent"], cfg["reps"])
        tick()
        sandbox = frame_times(gl, cfg["bodies"], frames or cfg["frames"], tick=tick)
        scratches = scratch_frames(gl, cfg["bodies"][0], frames or cfg["frames"])
        tick()
        if bar is not None:
            bar.close()
        result = {
            "schema": 1,
            "dentdemo": VERSION,
            "mode": mode,
            "machine": {
                "renderer": gl.renderer,
                "gl_version": gl.version,
                "cores": os.cpu_count(),
                "platform": platform.platform(),
                "python": platform.python_version(),
            },
            "press": PRESS,
            "per_hit": rows,
            "burst": bursts,
            "same_dent": same,
            "passes": passes,
            "frames": sandbox,
            "scratches": scratches,
            "window": windows,
            "memory": memory(gl),
            "agreement": agreement,
            "seconds": time.perf_counter() - start,
        }
    finally:
        gl.release()
    return result
