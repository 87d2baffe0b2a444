"""The `dentdemo` command: one module per subcommand, shared arguments in `args`, and here the
rules every command keeps: errors are one line with a non-zero exit, warnings are one line
prefixed `dentdemo:` (silenced by --quiet), Ctrl-C ends any command with status 130."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from types import ModuleType

from dentdemo import interrupt, log
from dentdemo.cli import args as cli_args
from dentdemo.cli import (
    bench,
    demo,
    indent,
    info,
    materials,
    render,
    replay,
    scratch,
    simulate,
)
from dentdemo.errors import DentdemoError, ShaderError
from dentdemo.version import VERSION

Handler = Callable[[argparse.Namespace], int]

#: Subcommands in the order `dentdemo --help` lists them; each has register(sub) and run(args).
COMMANDS: list[ModuleType] = [
    demo,
    render,
    replay,
    simulate,
    indent,
    scratch,
    bench,
    materials,
    info,
]

EXAMPLES = """examples:
  dentdemo demo                                  the interactive sandbox
  dentdemo render --frames 240 --out ball.png    a headless render of the ball-drop scene
  dentdemo indent --depth 0.002 --out press/     one deterministic press, no physics
  dentdemo COMMAND --help                        a command's options with their defaults"""


def build_parser() -> argparse.ArgumentParser:
    parser = cli_args.Parser(
        prog="dentdemo",
        description="Permanent dents from collisions, carved into bump maps on the GPU.",
        epilog=EXAMPLES,
        formatter_class=cli_args.HelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"dentdemo {VERSION}")
    cli_args.add_quiet(parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=cli_args.Parser)
    for module in COMMANDS:
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    interrupt.install()
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        log.configure(bool(getattr(args, "quiet", False)))
        handler: Handler | None = getattr(args, "handler", None)
        if handler is None:
            parser.print_help()
            return 2
        # Ctrl-C is honoured at the safe points inside the work (each frame, step or press, and
        # before each output after the last frame); one that comes after the last output was
        # written stops nothing, and the command reports its outputs and succeeds.
        return handler(args)
    except ShaderError as exc:  # file and line of each compiler message
        print(str(exc), file=sys.stderr)
        return 1
    except DentdemoError as exc:
        print(str(exc).splitlines()[0], file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("dentdemo: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
