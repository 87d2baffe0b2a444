"""`dentdemo demo`: the interactive window, or a headless PNG when there is no display."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from dentdemo.app.headless import add_scene_arguments, render_headless, scene_path
from dentdemo.errors import DentdemoError, GLUnavailableError
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene

HEADLESS_FALLBACK = Path("dentdemo_demo.png")


def run_demo(args: argparse.Namespace) -> int:
    if args.exit_after is not None and not (args.exit_after >= 0):
        raise DentdemoError(f"--exit-after must be >= 0 seconds, got {args.exit_after}")
    materials = load_materials(args.materials)
    path = scene_path(args.scene)
    scene = load_scene(path, materials)
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        return _headless_instead(args, path, "no display (DISPLAY is not set)")
    from dentdemo.app.window import DemoWindow

    try:
        window = DemoWindow(scene, materials)
    except GLUnavailableError as exc:
        return _headless_instead(args, path, str(exc).removeprefix("dentdemo: "))
    shot = Path(args.screenshot) if args.screenshot else None
    return window.run(shot, args.exit_after if (shot or args.exit_after is not None) else None)


def _headless_instead(args: argparse.Namespace, path: Path, why: str) -> int:
    out = Path(args.screenshot) if args.screenshot else HEADLESS_FALLBACK
    seconds = args.exit_after if args.exit_after is not None else 3.0
    materials = load_materials(args.materials)
    frames = max(1, round(seconds / load_scene(path, materials).physics.dt))
    print(
        f"dentdemo: {why}; rendering the same scene headless instead ({frames} frames) to {out}",
        file=sys.stderr,
    )
    render_headless(path, args.materials, frames, out, (1280, 720))
    print(f"wrote {out}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo", help="the interactive ball-drop sandbox (headless PNG without a display)"
    )
    add_scene_arguments(p)
    p.add_argument(
        "--screenshot", metavar="PNG", help="save the window's image (with --exit-after)"
    )
    p.add_argument(
        "--exit-after",
        type=float,
        metavar="SECONDS",
        help="simulated seconds after which to save the screenshot and exit",
    )
    p.set_defaults(handler=run_demo)
