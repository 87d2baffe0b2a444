"""Arguments more than one command takes, declared once, and the value types that check them (each
rejection names the flag and the value, on one line)."""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn

from dentdemo.outputs import check_output_file
from dentdemo.resources import assets_dir

DEFAULT_SCENE = "scenes/ball_drop.toml"


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (`dentdemo render: --frames: ...`), exit status 2."""

    def error(self, message: str) -> NoReturn:
        message = re.sub(r"^argument ([^:]+): ", r"\1: ", message)
        self.exit(2, f"{self.prog}: {message}\n")


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Each option's default after its help text (where it has one worth showing); the epilog
    (an example) kept as written."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (
            default is None
            or default is False
            or default == []
            or default == argparse.SUPPRESS
            or "%(default)" in text
            or action.option_strings == []
        ):
            return text
        return text + " (default: %(default)s)"


def command(
    sub: argparse._SubParsersAction, name: str, summary: str, example: str
) -> argparse.ArgumentParser:
    """A subcommand's parser with the shared options and one example in its --help."""
    parser: argparse.ArgumentParser = sub.add_parser(
        name,
        help=summary,
        description=summary[0].upper() + summary[1:] + ".",
        epilog=f"example:\n  {example}",
        formatter_class=HelpFormatter,
    )
    add_quiet(parser)
    return parser


def add_quiet(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--quiet",
        "-q",
        action="store_true",
        default=argparse.SUPPRESS,
        help="silence warnings (errors are still printed)",
    )


def add_materials(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--materials",
        action="append",
        default=[],
        metavar="FILE",
        help="a TOML file that adds or overrides material presets; repeatable, later files win",
    )


def add_scene(parser: argparse.ArgumentParser, required: bool = False) -> None:
    """--scene (the ball-drop scene when optional) and --materials."""
    parser.add_argument(
        "--scene",
        metavar="FILE",
        required=required,
        default=None if required else str(assets_dir() / DEFAULT_SCENE),
        help="scene TOML file",
    )
    add_materials(parser)


def add_backend(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--backend",
        choices=("egl", "glx"),
        default=None,
        help="headless GL backend (default: $DENTDEMO_GL_BACKEND, else egl)",
    )


def add_quality(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--quality",
        choices=("low", "medium", "high"),
        default=None,
        help="render quality preset (default: low on a software rasteriser, high on a GPU)",
    )


def add_gltf(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument(
        "--gltf",
        metavar="FILE",
        help=f"{what}: glTF 2.0, .glb (binary) or .gltf (opens in Blender and web viewers)",
    )


def check_gltf(text: str | None) -> Path | None:
    """The --gltf path, checked before any work: writable, and .glb or .gltf (an empty one is
    an error, not the flag left out)."""
    if text is None:
        return None
    from dentdemo.gltf import SUFFIXES

    return check_output_file("--gltf", text, SUFFIXES)


def int_in(lo: int, hi: int) -> Callable[[str], int]:
    """An integer lo <= n <= hi (no float silently truncated)."""

    def parse(text: str) -> int:
        try:
            value = int(text, 10)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got '{text}'") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must lie in [{lo}, {hi}], got {value}")
        return value

    parse.__name__ = "integer"
    return parse


def float_in(lo: float, hi: float, lo_open: bool = False) -> Callable[[str], float]:
    """A finite number in [lo, hi] ((lo, hi] with lo_open)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got '{text}'") from None
        below = value <= lo if lo_open else value < lo
        if not math.isfinite(value) or below or value > hi:
            left = "(" if lo_open else "["
            raise argparse.ArgumentTypeError(f"must lie in {left}{lo:g}, {hi:g}], got '{text}'")
        return value

    parse.__name__ = "number"
    return parse


def size_wxh(text: str) -> tuple[int, int]:
    """`1280x720`: width and height in pixels, each in [16, 8192]."""
    match = re.fullmatch(r"(\d+)x(\d+)", text.strip())
    if not match:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT such as 1280x720, got '{text}'")
    w, h = int(match.group(1)), int(match.group(2))
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise argparse.ArgumentTypeError(f"must lie between 16x16 and 8192x8192, got '{text}'")
    return w, h


def add_compact_state(parser: argparse.ArgumentParser, saves: str) -> None:
    """--compact-state [HITS]: saved states as a checkpoint and the hit log since it."""
    parser.add_argument(
        "--compact-state",
        type=int_in(0, 10**9),
        nargs="?",
        const=1000,
        default=None,
        metavar="HITS",
        help=f"{saves} a checkpoint and the hit log since it instead of every map (a new"
        " checkpoint once the log holds HITS hits, 1000 if not given)",
    )
