"""`dentdemo render`: a scene simulated at its fixed dt and drawn on EGL; the same Simulation and
Renderer as the window, with no window."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from PIL import Image

from dentdemo.errors import DentdemoError
from dentdemo.gl.context import create_headless
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
from dentdemo.render.camera import OrbitCamera
from dentdemo.render.renderer import Renderer, RenderOptions
from dentdemo.resources import assets_dir

DEFAULT_SCENE = "scenes/ball_drop.toml"


def parse_size(text: str) -> tuple[int, int]:
    match = re.fullmatch(r"(\d+)x(\d+)", text.strip())
    if not match:
        raise DentdemoError(f"--size must look like 1280x720, got '{text}'")
    w, h = int(match.group(1)), int(match.group(2))
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise DentdemoError(f"--size must lie between 16x16 and 8192x8192, got '{text}'")
    return w, h


def scene_path(arg: str | None) -> Path:
    return Path(arg) if arg else assets_dir() / DEFAULT_SCENE


def save_png(pixels, path: Path) -> None:
    """Write atomically: a half-written PNG never replaces a good one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    try:
        Image.fromarray(pixels).save(tmp, format="PNG")
        tmp.replace(path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise DentdemoError(f"{path}: cannot write image ({exc.strerror or exc})") from None


def render_headless(
    scene_file: Path,
    materials_files: list[Path],
    frames: int,
    out: Path,
    size: tuple[int, int],
    maps_dir: Path | None = None,
    denting: bool = True,
    options: RenderOptions | None = None,
) -> None:
    """Simulate `frames` steps and write the last frame (every frame when `out` has %d)."""
    from dentdemo.app.simulation import Simulation  # loads ODE

    if frames < 1:
        raise DentdemoError(f"--frames must be at least 1, got {frames}")
    materials = load_materials(materials_files)
    scene = load_scene(scene_file, materials)
    every = "%" in out.name
    if every:
        try:
            out.name % 0
        except (TypeError, ValueError):
            raise DentdemoError(f"--out: '{out.name}' has a bad % pattern (use %04d)") from None
    gl = create_headless()
    try:
        sim = Simulation(gl, scene, materials, denting=denting)
        renderer = Renderer(gl, size)
        camera = OrbitCamera.from_eye(scene.camera.eye, scene.camera.target, scene.camera.fov_deg)
        opts = options or RenderOptions()
        for frame in range(frames):
            sim.step()
            if every or frame == frames - 1:
                renderer.render(sim, camera, opts)
                target = out.with_name(out.name % frame) if every else out
                save_png(renderer.read_rgb(), target)
        sim.apply_queued()  # what the budget deferred, before the maps are exported
        if maps_dir is not None:
            sim.export_maps(maps_dir)
        renderer.release()
        sim.close()
    finally:
        gl.release()


def run_render(args: argparse.Namespace) -> int:
    render_headless(
        scene_path(args.scene),
        args.materials,
        args.frames,
        Path(args.out),
        parse_size(args.size),
        Path(args.maps_dir) if args.maps_dir else None,
        denting=not args.no_dents,
        options=RenderOptions(parallax=args.parallax, view=args.view),
    )
    print(f"wrote {args.out}")
    return 0


def add_scene_arguments(p: argparse.ArgumentParser) -> None:
    """--scene and --materials, as every command that loads a scene takes them."""
    p.add_argument("--scene", metavar="FILE", help="scene TOML (default: the ball-drop scene)")
    p.add_argument(
        "--materials",
        action="append",
        default=[],
        metavar="FILE",
        help="a TOML file that adds or overrides material presets (repeatable)",
    )


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("render", help="simulate a scene headless (EGL) and write PNG frames")
    add_scene_arguments(p)
    p.add_argument("--frames", type=int, default=120, help="simulation frames at the scene's dt")
    p.add_argument(
        "--out", required=True, metavar="PNG", help="output image; %%04d writes every frame"
    )
    p.add_argument("--size", default="1280x720", metavar="WxH")
    p.add_argument(
        "--maps-dir", metavar="DIR", help="also write every body's height and normal maps"
    )
    p.add_argument("--no-dents", action="store_true", help="detect impacts but carve nothing")
    p.add_argument("--parallax", action="store_true", help="parallax occlusion mapping")
    p.add_argument(
        "--view",
        type=int,
        choices=(0, 1, 2),
        default=0,
        help="0 shaded, 1 height map, 2 normal map",
    )
    p.set_defaults(handler=run_render)
