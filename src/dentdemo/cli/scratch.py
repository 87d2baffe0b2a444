"""`dentdemo scratch`: a tool dragged at constant load along a target, the groove Archard's law
wears carved with no physics, its maps and summary (predicted against measured volume, the
groove's cross-section) written to a folder."""

from __future__ import annotations

import argparse
import json
import math

from dentdemo import log
from dentdemo.cli.args import add_materials, command, float_in, int_in
from dentdemo.errors import DentdemoError
from dentdemo.outputs import PNG, check_output_dir, check_output_file


def register(sub: argparse._SubParsersAction) -> None:
    p = command(
        sub,
        "scratch",
        "drag a tool along a target at constant load: the groove of Archard's wear law",
        "dentdemo scratch --tool sphere --tool-size 0.01 --load 50 --distance 0.2 --speed 0.5 "
        "--target-material aluminium --out S/",
    )
    p.add_argument(
        "--tool",
        choices=("sphere", "box", "capsule", "cylinder", "plate"),
        default="sphere",
        help="tool shape, lying along the path (a plate face down)",
    )
    p.add_argument(
        "--tool-size",
        type=float_in(0.0, 100.0, lo_open=True),
        nargs="+",
        default=[0.01],
        metavar="M",
        help="sphere radius; box edge (or x y z, z along the path); capsule or cylinder radius "
        "[length]; plate side, metres",
    )
    p.add_argument(
        "--load", type=float_in(0.0, 1e9), required=True, help="normal force on the tool, N"
    )
    p.add_argument(
        "--distance",
        type=float_in(0.0, 100.0, lo_open=True),
        required=True,
        help="how far the tool travels along the target, m",
    )
    p.add_argument(
        "--speed",
        type=float_in(0.0, 1e6, lo_open=True),
        default=1.0,
        help="how fast it travels, m/s (Archard's volume does not depend on it)",
    )
    p.add_argument(
        "--slip",
        type=float_in(0.0, 1.0),
        default=1.0,
        help="the part of the way the tool slides: 1 dragged, 0 rolling without slip",
    )
    p.add_argument("--roll", action="store_true", help="the tool rolls without slipping (--slip 0)")
    p.add_argument(
        "--heading",
        type=float_in(-360.0, 360.0),
        default=0.0,
        help="the path's direction on the target, degrees from +x towards +z",
    )
    p.add_argument(
        "--target",
        choices=("plate", "box", "sphere"),
        default="plate",
        help="target shape: a plate, or a cube, sized to hold the path, or a sphere dragged along "
        "a great circle through its top by a sphere or a box (the groove's cross-section is "
        "measured on a plate)",
    )
    p.add_argument(
        "--target-radius",
        type=float_in(0.0, 100.0, lo_open=True),
        default=None,
        metavar="M",
        help="a sphere target's radius, m (default: the distance, an arc of one radian)",
    )
    p.add_argument(
        "--target-material", default="aluminium", metavar="NAME", help="the target's preset"
    )
    add_materials(p)
    p.add_argument(
        "--map-size",
        type=int_in(16, 8192),
        default=None,
        help="target map side, texels (default: 4 texels across the groove's half-width, "
        "up to 8192)",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument(
        "--render",
        metavar="PNG",
        help="also write the groove seen from above: the heights, black at the groove's depth",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from dentdemo.app.press import shape_from_args
    from dentdemo.app.scratch import (
        TEXELS_PER_HALF_WIDTH,
        Drag,
        auto_map_size,
        carve_groove,
        groove_for,
        make_scratch,
        target_for,
        write_scratch,
    )
    from dentdemo.gl.context import create_headless
    from dentdemo.mesh.shapes import Tessellation, shape_mesh
    from dentdemo.model.materials import load_materials
    from dentdemo.outputs import write_height_png

    if args.roll and args.slip not in (0.0, 1.0):
        raise DentdemoError(f"--roll: rolls without slip; it contradicts --slip {args.slip:g}")
    tool = shape_from_args(args.tool, args.tool_size, "tool")
    material = load_materials(args.materials).get(args.target_material, "--target-material")
    drag = Drag(args.load, args.distance, args.speed, 0.0 if args.roll else args.slip)
    if args.target_radius is not None and args.target != "sphere":
        raise DentdemoError(f"--target-radius: sizes a sphere target, not --target {args.target}")
    target = target_for(
        args.target, drag, groove_for(tool, material, drag), tool, args.target_radius
    )
    groove = groove_for(tool, material, drag, target)
    map_size = args.map_size or auto_map_size(target, groove)
    texel = max(shape_mesh(target, Tessellation.press(2)).uv_scale()) / map_size
    if groove.depth >= material.max_dent_depth:
        raise DentdemoError(
            f"--load/--distance: the groove would be {groove.depth:g} m deep, past "
            f"{args.target_material}'s max_dent_depth_m {material.max_dent_depth:g} m"
        )
    if groove.depth > 0 and groove.half_width < TEXELS_PER_HALF_WIDTH * texel:
        log.warn(
            f"the groove's half-width {groove.half_width:.3g} m spans "
            f"{groove.half_width / texel:.1f} texels of {texel:.3g} m: its measured volume is "
            f"sampled coarsely (within -1/(4 n^2) .. +1/(8 n^2) for n texels)"
        )
    out = check_output_dir("--out", args.out)
    render = check_output_file("--render", args.render, PNG) if args.render is not None else None
    gl = create_headless()
    try:
        setup = make_scratch(gl, target, tool, material, drag, map_size, math.radians(args.heading))
        carved = carve_groove(gl, setup)
        summary = write_scratch(gl, setup, out, carved)
        summary["target_material"] = args.target_material
        if render is not None:
            height = gl.read(setup.target.maps.height)[:, :, 0]
            write_height_png(render, height, groove.depth or material.max_dent_depth)
            summary["render"] = str(render)
    finally:
        gl.release()
    print(json.dumps(summary, indent=2))
    return 0
