"""`dentdemo indent`: a deterministic press with no physics, its maps and summary written to a
folder."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING

from dentdemo import log
from dentdemo.cli.args import add_gltf, add_quality, check_gltf, command, float_in, int_in, size_wxh
from dentdemo.errors import DentdemoError
from dentdemo.outputs import PNG, check_output_dir, check_output_file, write_json

if TYPE_CHECKING:
    from dentdemo.app.press import PressSetup
    from dentdemo.gl.context import GLContext

MAP_SIDES = int_in(16, 8192)


def register(sub: argparse._SubParsersAction) -> None:
    p = command(
        sub,
        "indent",
        "press a tool into a target on the GPU, no physics",
        "dentdemo indent --tool sphere --tool-size 0.05 --depth 0.002 --out press/",
    )
    p.add_argument(
        "--tool", choices=("sphere", "box", "capsule"), default="sphere", help="tool shape"
    )
    p.add_argument(
        "--tool-size",
        type=float_in(0.0, 100.0, lo_open=True),
        nargs="+",
        default=[0.05],
        metavar="M",
        help="sphere radius; box edge (or x y z); capsule radius [length], metres",
    )
    p.add_argument(
        "--target", choices=("plate", "box", "sphere"), default="plate", help="target shape"
    )
    p.add_argument(
        "--target-size",
        type=float_in(0.0, 100.0, lo_open=True),
        nargs="+",
        default=[1.0],
        metavar="M",
        help="plate side; box edge (or x y z); sphere radius, metres",
    )
    p.add_argument(
        "--depth", type=float_in(0.0, 1.0), required=True, help="dent the target receives, m"
    )
    p.add_argument(
        "--offset",
        type=float_in(-100.0, 100.0),
        nargs=2,
        default=[0.0, 0.0],
        metavar=("X", "Z"),
        help="where on the target, metres from its centre",
    )
    p.add_argument(
        "--normal",
        type=float_in(-1e6, 1e6),
        nargs=3,
        default=[0.0, -1.0, 0.0],
        metavar=("X", "Y", "Z"),
        help="press direction (the way the tool moves)",
    )
    p.add_argument("--repeat", type=int_in(1, 10000), default=1, help="press this many times")
    p.add_argument("--map-size", type=MAP_SIDES, default=512, help="target map side, texels")
    p.add_argument(
        "--tool-map-size",
        type=MAP_SIDES,
        default=None,
        help="tool map side, texels (default: --map-size)",
    )
    p.add_argument("--tool-pattern", metavar="PNG", help="greyscale height pattern on the tool")
    p.add_argument(
        "--pattern-height",
        type=float_in(0.0, 1.0),
        default=0.002,
        help="height of white in the pattern, m",
    )
    p.add_argument(
        "--tool-depth", type=float_in(0.0, 1.0), default=0.0, help="dent the tool receives, m"
    )
    p.add_argument(
        "--max-dent-depth",
        type=float_in(0.0, 1.0, lo_open=True),
        default=0.1,
        help="deepest dent a map holds, m",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument(
        "--render",
        metavar="PNG",
        help="also draw the dented target seen from the side (across the press), whole, on a "
        "plain background (alpha 0), orthographic",
    )
    shown = p.add_mutually_exclusive_group()
    shown.add_argument(
        "--displace",
        dest="displace",
        action="store_true",
        default=None,
        help="--render moves the surface by its dents, so they show in the outline (default)",
    )
    shown.add_argument(
        "--no-displace",
        dest="displace",
        action="store_false",
        help="--render draws the dents in the maps only: the outline is the undented mesh's",
    )
    p.add_argument(
        "--render-size", type=size_wxh, default="1280x720", metavar="WxH", help="--render pixels"
    )
    add_gltf(p, "also write the target and the tool after the presses, with their maps")
    add_quality(p)
    p.set_defaults(handler=run)


def _clamped(flag: str, depth: float, deepest: float) -> float:
    """A press depth within the maps' bound, metres: a deeper one is pressed to the bound (as
    the material model clamps a dent, eq. 4), with one warning line saying so."""
    if depth <= deepest:
        return depth
    log.warn(
        f"{flag} {depth:g} m is deeper than --max-dent-depth {deepest:g} m: "
        f"clamped to {deepest:g} m"
    )
    return deepest


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from dentdemo.app.press import make_setup, run_presses, shape_from_args, write_outputs
    from dentdemo.carve.surface import load_height_png
    from dentdemo.gl.context import create_headless

    depth = _clamped("--depth", args.depth, args.max_dent_depth)
    tool_depth = _clamped("--tool-depth", args.tool_depth, args.max_dent_depth)
    direction = np.asarray(args.normal, dtype=np.float64)
    if np.linalg.norm(direction) < 1e-9:
        raise DentdemoError(f"--normal: must be a non-zero vector, got {args.normal}")
    target_shape = shape_from_args(args.target, args.target_size, "target")
    tool_shape = shape_from_args(args.tool, args.tool_size, "tool")
    tool_map = args.tool_map_size or args.map_size
    pattern = (
        load_height_png(Path(args.tool_pattern), tool_map, args.pattern_height)
        if args.tool_pattern
        else None
    )
    if args.render is None and args.displace is not None:
        flag = "--displace" if args.displace else "--no-displace"
        raise DentdemoError(f"{flag}: only with --render PNG")
    out = check_output_dir("--out", args.out)
    render = check_output_file("--render", args.render, PNG) if args.render is not None else None
    gltf = check_gltf(args.gltf)
    gl = create_headless()
    try:
        setup = make_setup(
            gl,
            target_shape,
            tool_shape,
            args.map_size,
            tool_map,
            tuple(args.offset),
            direction,
            args.max_dent_depth,
            pattern,
        )
        times = run_presses(gl, setup, depth, tool_depth, args.repeat)
        summary = write_outputs(gl, setup, out, depth, tool_depth, times)
        if render is not None:
            summary["render"] = _render(gl, setup, render, args)
        if gltf is not None:
            summary["gltf"] = str(_export(gl, setup, gltf))
        if render is not None or gltf is not None:
            write_json(out / "summary.json", summary)  # again, with what else was written
    finally:
        gl.release()
    print(json.dumps(summary, indent=2))
    return 0


def _export(gl: GLContext, setup: PressSetup, path: Path) -> Path:
    """`--gltf`: the target (a plate with its undented sides) and the tool at their poses after
    the presses, grey, each with its normal and height maps."""
    from dentdemo.gltf import GltfBody, GltfPart, dented_part, write_gltf
    from dentdemo.mesh.shapes import plate_sides
    from dentdemo.model.materials import Appearance
    from dentdemo.model.shapes import Plate

    look = Appearance()
    bodies = []
    for name, body, shape in (
        ("target", setup.target, setup.target_shape),
        ("tool", setup.tool, setup.tool_shape),
    ):
        parts = [dented_part(gl, body.gpu_mesh.mesh, look, body.maps)]
        if isinstance(shape, Plate):
            parts.append(GltfPart(plate_sides(shape), look, name="sides"))
        bodies.append(GltfBody(name, body.model, tuple(parts)))
    return write_gltf(path, bodies)


def _render(gl: GLContext, setup: PressSetup, path: Path, args: argparse.Namespace) -> dict:
    """`--render`: the target after the press, across the press direction; what was drawn."""
    from dentdemo.outputs import write_png
    from dentdemo.render.quality import preset
    from dentdemo.render.side_view import render_side_view

    target = setup.target
    view = render_side_view(
        gl,
        target.gpu_mesh,
        target.maps,
        target.model,
        setup.contact.direction,
        args.render_size,
        preset(args.quality, gl.software),
        args.displace is not False,
    )
    write_png(path, view.pixels)
    return {
        "png": str(path),
        "size": list(args.render_size),
        "metres_per_pixel": view.metres_per_pixel,
        "displacement": view.displacement,
    }
