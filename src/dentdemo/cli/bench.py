"""`dentdemo bench`: per-hit cost against map size (both update paths), the split by pass, frame
times against scene size, and the memory of the maps."""

from __future__ import annotations

import argparse

from dentdemo.cli.args import command, int_in
from dentdemo.errors import DentdemoError
from dentdemo.extras import require_app
from dentdemo.outputs import JSON, PNG, check_output_file, write_json


def register(sub: argparse._SubParsersAction) -> None:
    p = command(
        sub,
        "bench",
        "measure per-hit cost, both update paths, frame times (and the window's fps), memory",
        "dentdemo bench --quick --json bench.json --plot bench.png",
    )
    p.add_argument(
        "--quick", action="store_true", help="a shorter run (under a minute on llvmpipe)"
    )
    p.add_argument("--tiny", action="store_true", help=argparse.SUPPRESS)  # the test suite's mode
    p.add_argument("--json", metavar="FILE", help="write the results as JSON")
    p.add_argument("--plot", metavar="PNG", help="plot cost per hit against map size")
    p.add_argument(
        "--frames",
        type=int_in(1, 100000),
        metavar="N",
        help="sandbox frames timed per body count (default: the mode's; 120 or more separate "
        "the carve per hit of two builds)",
    )
    p.add_argument(
        "--window",
        action="store_true",
        help="also run the interactive window (a display is needed, Xvfb will do) and report its "
        "frames per second by quality preset and body count",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from dentdemo.bench.report import plot, print_table
    from dentdemo.bench.run import run_bench

    json_path = check_output_file("--json", args.json, JSON) if args.json is not None else None
    plot_path = check_output_file("--plot", args.plot, PNG) if args.plot is not None else None
    from dentdemo.gl.context import has_display

    if args.window:
        require_app("--window", "glfw", "imgui_bundle")
    if args.window and not has_display():
        raise DentdemoError("--window: no display (DISPLAY is not set); run it under X or Xvfb")
    mode = "tiny" if args.tiny else ("quick" if args.quick else "full")
    result = run_bench(mode, window=args.window, frames=args.frames)
    print_table(result)
    if json_path is not None:
        write_json(json_path, result)
    if plot_path is not None:
        plot(result, plot_path)
    return 0
