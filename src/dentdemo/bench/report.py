"""The benchmark's report: the table on stdout and the cost-per-hit plot (a PNG drawn with Pillow),
both from the result dictionary `bench.run.run_bench` returns."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from dentdemo.outputs import write_bytes


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
    bursts = r.get("burst", [])
    if bursts:
        print(
            f"{'burst':>6} {'map':>6} {'batched ms/hit':>15} {'(plan':>7} {'submit':>7} "
            f"{'wait)':>7} {'main CPU':>9} {'one by one':>11} {'CPU path':>9} {'GL calls':>9}"
            "  (amortised per hit; main CPU: the main thread's; GL calls a batch)"
        )
        for b in bursts:
            cpu = f"{b['cpu_ms_per_hit']:9.2f}" if b["cpu_ms_per_hit"] is not None else f"{'-':>9}"
            thread = b.get("main_thread_ms_per_hit")
            main = f"{thread:.3f}" if thread is not None else "-"
            calls = b.get("gl_calls_per_batch")
            counted = f"{calls:>9}" if calls is not None else f"{'-':>9}"
            print(
                f"{b['hits']:>6} {b['map_size']:>5}² {b['gpu_ms_per_hit']:15.3f} "
                f"{b['plan_ms_per_hit']:7.3f} {b['submit_ms_per_hit']:7.3f} "
                f"{b['wait_ms_per_hit']:7.3f} {main:>9} {b['serial_ms_per_hit']:11.3f} {cpu} "
                f"{counted}"
            )
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
        f" {'hits':>6} {'carve/hit':>9} {'plan/hit':>8} {'undo/hit':>8} {'proxy/hit':>9}"
        "  (1280x720; medians a frame, per hit over all frames; plan: pass 1, undo: the"
        " snapshots, proxy: the collision proxies' presses, each part of carve)"
    )
    for f in r["frames"]:
        parts = [
            ("carve_ms_per_hit", 9),
            ("plan_ms_per_hit", 8),
            ("undo_ms_per_hit", 8),
            ("proxies_ms_per_hit", 9),
        ]
        print(
            f"{f['bodies']:>6} {f['frame_ms']:9.1f} {f['physics_ms']:8.1f} "
            f"{f['carve_ms']:7.1f} {f['render_ms']:7.1f} {f['hits']:>6}"
            + "".join(
                f" {f[key]:{width}.2f}" if f.get(key) is not None else f" {'-':>{width}}"
                for key, width in parts
            )
        )
    if r.get("scratches"):
        sc = r["scratches"]
        print(
            f"{'scratches':>9}: {sc['bodies']} bodies, frame ms {sc['frame_ms_without']:.1f} "
            f"without, {sc['frame_ms_with']:.1f} with (ratio {sc['ratio']:.3f}; wear_scale "
            f"{sc['wear_scale']:g}, {sc['grooves']} grooves; medians of {sc['frames']} frames "
            "each, the two sandboxes stepped in turn)"
        )
    if r.get("window"):
        size = "x".join(str(v) for v in r["window"][0]["size"])
        print(
            f"{'window':>8} {'bodies':>6} {'fps':>6} {'median ms':>10} {'p90 ms':>7}"
            f"  (real window {size}, wall clock, panel on)"
        )
        for w in r["window"]:
            print(
                f"{w['quality']:>8} {w['bodies']:>6} {w['fps']:6.1f} "
                f"{w['frame_ms_median']:10.1f} {w['frame_ms_p90']:7.1f}"
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
