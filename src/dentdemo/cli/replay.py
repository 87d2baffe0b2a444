"""`dentdemo replay`: a hit log (`render --hit-log`, `demo --hit-log`) carved back onto a scene's
bodies with no physics, the maps written like `render --maps-dir`."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from dentdemo.cli.args import add_scene, command, size_wxh
from dentdemo.outputs import check_output_dir, check_output_file


def register(sub: argparse._SubParsersAction) -> None:
    p = command(
        sub,
        "replay",
        "carve a hit log onto a scene's bodies, no physics, and write their maps",
        "dentdemo replay --hit-log hits.ddhl --maps-dir maps/",
    )
    add_scene(p)
    p.add_argument(
        "--hit-log", required=True, metavar="FILE", help="a log written by --hit-log (either form)"
    )
    p.add_argument(
        "--maps-dir", required=True, metavar="DIR", help="every body's height and normal maps"
    )
    p.add_argument(
        "--out", metavar="PNG", help="also a picture of the scene's bodies, dented, at rest"
    )
    p.add_argument("--size", type=size_wxh, default="1280x720", metavar="WxH", help="pixels")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from dentdemo.app.hitlog import read_log, replay
    from dentdemo.gl.context import create_headless
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene

    maps_dir = check_output_dir("--maps-dir", Path(args.maps_dir))
    out = check_output_file("--out", Path(args.out)) if args.out else None
    materials = load_materials(args.materials)
    scene = load_scene(Path(args.scene), materials)
    records, places = read_log("--hit-log", Path(args.hit_log))
    gl = create_headless()
    try:
        from dentdemo.app.controller import DemoController  # loads ODE
        from dentdemo.app.export import export_maps

        app = DemoController(gl, scene, materials, args.size)
        start = time.perf_counter()
        hits = replay(app.sim, records, places)
        gl.ctx.finish()
        seconds = time.perf_counter() - start
        export_maps(app.sim, maps_dir)
        if out is not None:
            app.screenshot(out)
        app.close()
    finally:
        gl.release()
    print(f"replayed {hits} hits of {len(records)} records in {seconds:.2f} s")
    print(f"wrote {maps_dir}")
    if out is not None:
        print(f"wrote {out}")
    return 0
