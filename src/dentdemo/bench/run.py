"""The benchmark: per-hit cost against map size (GPU path and the paper's CPU path), the split by
pass, sandbox frame times against scene size, and the memory of the maps."""

from __future__ import annotations

import io
import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from dentdemo import __version__, interrupt
from dentdemo.app.press import make_setup, shape_from_args
from dentdemo.bench.timing import PassTimer, interleaved_medians, median_ms
from dentdemo.carve.carver import Carver
from dentdemo.carve.cpu_reference import CpuReference
from dentdemo.gl.context import GLContext, create_headless
from dentdemo.outputs import write_bytes

#: The press every per-hit measurement uses: a 5 cm ball 1 cm into a 1 m plate, the ball 2 mm.
PRESS = {"tool_radius_m": 0.05, "plate_side_m": 1.0, "depth_m": 0.01, "tool_depth_m": 0.002}
#: Tessellation of the bench's meshes (Shape.mesh detail): 2 as measured before carve v2.
DETAIL = 2
#: The same dent in texels on plates of growing size (plate side m, map side): the cost of a hit
#: must follow its footprint, not the map.
SAME_DENT = [(0.5, 512), (4.0, 4096)]
MODES = {
    "tiny": {
        "sizes": [128, 256],
        "reps": 2,
        "bodies": [8],
        "frames": 4,
        "cpu_sizes": [128, 256],
        "same_dent": [(0.25, 128), (0.5, 256)],
    },
    "quick": {
        "sizes": [256, 1024, 4096],
        "reps": 5,
        "bodies": [20, 100],
        "frames": 20,
        "cpu_sizes": [256, 1024, 4096],
        "same_dent": SAME_DENT,
    },
    "full": {
        "sizes": [256, 512, 1024, 2048, 4096],
        "reps": 15,
        "bodies": [20, 100, 500],
        "frames": 60,
        "cpu_sizes": [256, 512, 1024, 2048, 4096],
        "same_dent": SAME_DENT,
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


def _press(setup) -> tuple:
    return (setup.target, setup.tool, setup.contact, PRESS["depth_m"], PRESS["tool_depth_m"])


def same_dent(gl: GLContext, plates: list[tuple[float, int]], reps: int) -> list[dict]:
    """Median ms per press (both bodies) of the same dent, in metres and in texels, on plates
    whose maps grow with their side; the plates take turns within each repetition."""
    carver = Carver(gl)
    setups = [_press_setup(gl, size, side) for side, size in plates]
    presses = [_press(setup) for setup in setups]
    runs = [lambda press=press: carver.carve(*press) for press in presses]
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


def _release(setup) -> None:
    for body in (setup.target, setup.tool):
        body.maps.release()
        body.gpu_mesh.release()


def per_hit(
    gl: GLContext, sizes: list[int], cpu_sizes: list[int], reps: int
) -> tuple[list, list, dict]:
    """Median ms per press (both bodies) for both paths, and the per-pass split."""
    carver = Carver(gl)
    rows, passes = [], []
    agreement = {"max_abs_diff_m": 0.0}
    finish = gl.ctx.finish
    for size in sizes:
        gpu_setup = _press_setup(gl, size)
        press = _press(gpu_setup)
        gpu_ms, _ = median_ms(lambda press=press: carver.carve(*press), finish, reps)
        timer = PassTimer(gl.ctx)
        carver.pass_timer = timer
        for _ in range(reps):
            interrupt.check()
            carver.carve(*press)
            timer.end_hit()
        carver.pass_timer = None
        for name, ms in timer.medians().items():
            passes.append({"map_size": size, "pass": name, "ms": ms, "gpu_timer": timer.gpu})
        pixels = [job.camera.pixels for job in carver.last_jobs]
        row = {
            "map_size": size,
            "gpu_ms": gpu_ms,
            "reps": reps,
            # Collision-camera pixels of both directions: the plate dented, the ball dented.
            "camera_pixels": pixels,
        }
        if size in cpu_sizes:
            cpu_setup = _press_setup(gl, size)
            reference = CpuReference(gl, carver)
            for body in (cpu_setup.target, cpu_setup.tool):
                reference.mirror(body)  # the CPU path's own copy, made once, outside the timing
            cpu_press = _press(cpu_setup)
            cpu_ms, _ = median_ms(lambda ref=reference, p=cpu_press: ref.carve(*p), finish, reps)
            row["cpu_ms"] = cpu_ms
            row["cpu_over_gpu"] = cpu_ms / gpu_ms if gpu_ms > 0 else None
            diff = np.abs(
                gl.read(gpu_setup.target.maps.height) - gl.read(cpu_setup.target.maps.height)
            ).max()
            agreement["max_abs_diff_m"] = max(agreement["max_abs_diff_m"], float(diff))
            _release(cpu_setup)
        rows.append(row)
        _release(gpu_setup)
    carver.release()
    return rows, passes, agreement


def frame_times(gl: GLContext, body_counts: list[int], frames: int, size=(1280, 720)) -> list[dict]:
    """Sandbox frames through the frame loop (physics step, carves, render at `size`) with N
    bodies dropped on plates; each phase ends with glFinish so that its time is its own."""
    from dentdemo.app.controller import DemoController
    from dentdemo.app.loop import FrameLoop, ImageBackend
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene
    from dentdemo.resources import assets_dir

    materials = load_materials()
    scene = load_scene(assets_dir() / "scenes" / "ball_drop.toml", materials)
    out = []
    for count in body_counts:
        app = DemoController(gl, scene, materials, size)
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
        loop = FrameLoop(app, ImageBackend(size, None), fixed_dt=True)
        timings = [loop.frame(measure=True) for _ in range(frames)]
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
                "hits": app.sim.stats.hits,
            }
        )
        app.close()
    return out


def memory(gl: GLContext) -> dict:
    from dentdemo.carve.surface import BYTES_PER_TEXEL

    per_texel = BYTES_PER_TEXEL
    return {
        "bytes_per_texel": per_texel,
        "layout": "R32F height (4) + RGBA8 normal (4) + R8 chart mask (1)",
        "map_bytes": {str(s): s * s * per_texel for s in (256, 512, 1024, 2048, 4096)},
        # Two directions: address RGBA32F (16) + tool depth and coverage RG32F (8) + depth (4).
        "scratch_bytes": 2 * 1023 * 1023 * (16 + 8 + 4),
    }


def run_bench(mode: str) -> dict:
    cfg = MODES[mode]
    gl = create_headless()
    try:
        start = time.perf_counter()
        rows, passes, agreement = per_hit(gl, cfg["sizes"], cfg["cpu_sizes"], cfg["reps"])
        same = same_dent(gl, cfg["same_dent"], cfg["reps"])
        frames = frame_times(gl, cfg["bodies"], cfg["frames"])
        result = {
            "schema": 1,
            "dentdemo": __version__,
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
            "same_dent": same,
            "passes": passes,
            "frames": frames,
            "memory": memory(gl),
            "agreement": agreement,
            "seconds": time.perf_counter() - start,
        }
    finally:
        gl.release()
    return result


def print_table(r: dict) -> None:
    m = r["machine"]
    print(
        f"dentdemo {r['dentdemo']} bench ({r['mode']}) on {m['renderer']}, "
        f"{m['cores']} cores, {m['gl_version']}"
    )
    print(
        f"press: {r['press']['tool_radius_m']} m ball {r['press']['depth_m']} m into a "
        f"{r['press']['plate_side_m']} m plate, ball dented {r['press']['tool_depth_m']} m; "
        f"medians of "
        f"{r['per_hit'][0]['reps']} after 2 warm-ups"
    )
    print(
        f"{'map':>6} {'cam px plate':>12} {'cam px ball':>11} {'GPU ms/hit':>11} "
        f"{'CPU-path ms':>12} {'CPU/GPU':>8}"
    )
    for row in r["per_hit"]:
        cpu = (
            f"{row['cpu_ms']:12.2f} {row['cpu_over_gpu']:8.2f}"
            if "cpu_ms" in row
            else f"{'-':>12} {'-':>8}"
        )
        px = [*row["camera_pixels"], 0, 0]
        print(f"{row['map_size']:>5}² {px[0]:>12} {px[1]:>11} {row['gpu_ms']:11.2f} {cpu}")
    same = r.get("same_dent", [])
    if same:
        print(
            "same dent in texels:  "
            + ";  ".join(
                f"{d['plate_side_m']:g} m plate at {d['map_size']}² {d['gpu_ms']:.2f} ms"
                for d in same
            )
            + f";  ratio {same[-1]['gpu_ms'] / same[0]['gpu_ms']:.2f}"
        )
    names = sorted(
        {p["pass"] for p in r["passes"]}, key=["address", "peel", "gather", "normals"].index
    )
    timer = "GPU timer queries" if r["passes"] and r["passes"][0]["gpu_timer"] else "wall time"
    print(f"by pass, ms ({timer}):  " + "  ".join(f"{n:>8}" for n in names))
    for size in [row["map_size"] for row in r["per_hit"]]:
        vals = {p["pass"]: p["ms"] for p in r["passes"] if p["map_size"] == size}
        print(f"{size:>5}²{'':19}" + "  ".join(f"{vals.get(n, 0):8.2f}" for n in names))
    print(
        f"{'bodies':>6} {'frame ms':>9} {'physics':>8} {'carve':>7} {'render':>7}"
        "  (1280x720, medians)"
    )
    for f in r["frames"]:
        print(
            f"{f['bodies']:>6} {f['frame_ms']:9.1f} {f['physics_ms']:8.1f} "
            f"{f['carve_ms']:7.1f} {f['render_ms']:7.1f}"
        )
    mem = r["memory"]
    print(
        f"maps: {mem['bytes_per_texel']} bytes/texel ({mem['layout']}); 1024² = "
        f"{mem['map_bytes']['1024'] / 2**20:.1f} MiB, "
        f"4096² = {mem['map_bytes']['4096'] / 2**20:.0f} MiB; "
        f"carve scratch {mem['scratch_bytes'] / 2**20:.0f} MiB"
    )
    print(
        f"CPU path vs GPU path: max |height difference| {r['agreement']['max_abs_diff_m']:.2e} m; "
        f"bench took {r['seconds']:.1f} s"
    )


def plot(r: dict, path: Path) -> None:
    """Cost per hit against map size, both paths, log-log, drawn with Pillow."""
    from PIL import Image, ImageDraw

    W, H, pad = 720, 440, 70
    img = Image.new("RGB", (W, H), "white")
    d = ImageDraw.Draw(img)
    rows = r["per_hit"]
    xs = [row["map_size"] for row in rows]
    ys = [row["gpu_ms"] for row in rows] + [row["cpu_ms"] for row in rows if "cpu_ms" in row]
    lx0, lx1 = np.log2(min(xs)), np.log2(max(xs)) if max(xs) > min(xs) else np.log2(min(xs)) + 1
    ly0, ly1 = np.log10(min(ys)) - 0.1, np.log10(max(ys)) + 0.1

    def to_px(x, y):
        return (
            pad + (np.log2(x) - lx0) / (lx1 - lx0) * (W - 2 * pad),
            H - pad - (np.log10(y) - ly0) / (ly1 - ly0) * (H - 2 * pad),
        )

    d.rectangle([pad, pad, W - pad, H - pad], outline="black")
    for x in xs:
        px, _ = to_px(x, 10**ly0)
        d.text((px - 14, H - pad + 6), f"{x}^2", fill="black")
    for e in range(int(np.floor(ly0)), int(np.ceil(ly1)) + 1):
        for m in (1, 1.5, 2, 3, 5, 7):
            y = m * 10.0**e
            if ly0 <= np.log10(y) <= ly1:
                _, py = to_px(min(xs), y)
                d.line([pad - 4, py, pad, py], fill="black")
                d.text((8, py - 6), f"{y:g} ms", fill="black")
    for key, colour, label in (
        ("gpu_ms", (30, 90, 200), "GPU-resident path (ours)"),
        ("cpu_ms", (200, 60, 30), "CPU update path (the paper's place for it)"),
    ):
        pts = [to_px(row["map_size"], row[key]) for row in rows if key in row]
        if len(pts) > 1:
            d.line(pts, fill=colour, width=3)
        for p in pts:
            d.ellipse([p[0] - 4, p[1] - 4, p[0] + 4, p[1] + 4], fill=colour)
        ly = 20 if key == "gpu_ms" else 38
        d.line([pad + 10, ly + 6, pad + 40, ly + 6], fill=colour, width=3)
        d.text((pad + 48, ly), label, fill="black")
    d.text((W // 2 - 120, H - 30), "height-map size (same dent in metres)", fill="black")
    d.text((W - pad - 260, 20), f"{r['machine']['renderer'][:38]}", fill="black")
    buffer = io.BytesIO()
    img.save(buffer, format="PNG")
    write_bytes(path, buffer.getvalue())
