"""`dentdemo demo`: the interactive window, or a headless PNG when there is no display."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from dentdemo import log
from dentdemo.cli.args import (
    add_compact_state,
    add_gltf,
    add_quality,
    add_scene,
    check_gltf,
    command,
    float_in,
    size_wxh,
)
from dentdemo.errors import DentdemoError, GLUnavailableError
from dentdemo.extras import require_app
from dentdemo.outputs import PNG, check_output_file

HEADLESS_FALLBACK = Path("dentdemo_demo.png")
#: Simulated seconds the headless fallback renders when --exit-after is not given.
FALLBACK_SECONDS = 3.0


def register(sub: argparse._SubParsersAction) -> None:
    p = command(
        sub,
        "demo",
        "the interactive ball-drop sandbox (a headless PNG without a display)",
        "dentdemo demo --screenshot shot.png --exit-after 2",
    )
    add_scene(p)
    p.add_argument(
        "--screenshot",
        metavar="PNG",
        help="save the window's image after --exit-after seconds (default 3) and exit",
    )
    p.add_argument(
        "--exit-after",
        type=float_in(0.0, 3600.0),
        metavar="SECONDS",
        help="simulated seconds after which to exit (saving --screenshot)",
    )
    p.add_argument("--size", type=size_wxh, default="1280x720", metavar="WxH", help="window pixels")
    p.add_argument(
        "--select",
        metavar="BODY",
        help="a body of the scene to select at start, for the developer tools (Ctrl + click "
        "selects in the window)",
    )
    add_quality(p)
    add_gltf(
        p,
        "where the G key and the panel's export button write every body (default dentdemo.glb); "
        "with --exit-after, also written when the run ends",
    )
    add_compact_state(p, "F5 saves")
    p.add_argument(
        "--hit-log",
        metavar="FILE",
        help="write every carve as a record when the demo ends: .ddhl (binary) or .jsonl;"
        " 'dentdemo replay' carves it back",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene

    require_app("the interactive demo", "glfw", "imgui_bundle")
    shot = None
    if args.screenshot is not None:
        shot = check_output_file("--screenshot", args.screenshot, PNG)
    gltf = check_gltf(args.gltf)
    hit_log = _hit_log(args)
    exit_after = args.exit_after
    if shot is not None and exit_after is None:
        exit_after = FALLBACK_SECONDS  # a screenshot always ends the run
    materials = load_materials(args.materials)
    path = Path(args.scene)
    scene = load_scene(path, materials)
    ids = [spec.id for spec in scene.bodies]
    if args.select is not None and args.select not in ids:
        raise DentdemoError(
            f"--select: no body '{args.select}' in {path} (bodies: {', '.join(ids)})"
        )
    from dentdemo.gl.context import has_display

    if not has_display():
        return _headless_instead(
            args, path, scene.physics.dt, exit_after, "no display (DISPLAY is not set)"
        )
    from dentdemo.app.window import DemoWindow

    try:
        window = DemoWindow(scene, materials, args.size, args.quality)
    except GLUnavailableError as exc:
        why = str(exc).removeprefix("dentdemo: ")
        return _headless_instead(args, path, scene.physics.dt, exit_after, why)
    if gltf is not None:
        window.app.export.path = gltf
    window.app.tools.selected = args.select
    window.app.tools.visible = args.select is not None  # --select opens the tools
    if args.compact_state is not None:
        from dentdemo.app.state import enable_compact_saves

        enable_compact_saves(window.app.sim, args.compact_state)
    window.app.reload.watch([Path(p) for p in args.materials], path)
    if args.materials:  # files the user named (the scene is watched too, silently)
        watched = [*args.materials, path]
        log.warn(f"dentdemo: watching {', '.join(map(str, watched))}: saved changes apply live")
    if hit_log is None:
        return window.run(shot, exit_after, gltf if exit_after is not None else None)
    from dentdemo.app.hitlog import HitRecorder, write_log

    recorder = HitRecorder()
    recorder.attach(window.app.sim)
    try:
        return window.run(shot, exit_after, gltf if exit_after is not None else None)
    finally:  # Esc, the end of --exit-after, or Ctrl-C: what was carved so far
        write_log(hit_log, recorder.records)
        print(f"wrote {hit_log} ({recorder.hits} hits)")


def _hit_log(args: argparse.Namespace) -> Path | None:
    if args.hit_log is None:
        return None
    from dentdemo.app.hitlog import check_log_path

    return check_log_path("--hit-log", Path(args.hit_log))


def _headless_instead(
    args: argparse.Namespace, path: Path, dt: float, exit_after: float | None, why: str
) -> int:
    """The same scene (its frame step `dt`, seconds) rendered headless, for lack of a window."""
    from dentdemo.app.headless import render_headless

    out = Path(args.screenshot) if args.screenshot is not None else HEADLESS_FALLBACK
    check_output_file("--screenshot", out, PNG)
    seconds = exit_after if exit_after is not None else FALLBACK_SECONDS
    frames = max(1, round(seconds / dt))
    print(
        f"dentdemo: {why}; rendering the same scene headless instead ({frames} frames) to {out}",
        file=sys.stderr,
    )
    gltf = check_gltf(args.gltf)
    hit_log = _hit_log(args)
    render_headless(
        path, args.materials, frames, out, args.size, quality=args.quality, gltf=gltf,
        hit_log=hit_log,
    )  # fmt: skip
    print(f"wrote {out}")
    for written in (gltf, hit_log):
        if written is not None:
            print(f"wrote {written}")
    return 0
