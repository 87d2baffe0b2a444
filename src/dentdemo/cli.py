"""The `dentdemo` command: subcommands, one-line errors, non-zero exits."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from dentdemo import __version__
from dentdemo.errors import DentdemoError

Handler = Callable[[argparse.Namespace], int]


def _cmd_materials(args: argparse.Namespace) -> int:
    import json

    from dentdemo.model.materials import load_materials

    library = load_materials(args.materials)
    if args.json:
        payload = {
            "sources": list(library.sources),
            "calibration": {
                "k_per_compliance": library.calibration.k_per_compliance,
                "Y_unit_Ns": library.calibration.Y_unit,
            },
            "materials": [library.materials[n].as_dict() for n in library.names()],
        }
        print(json.dumps(payload, indent=2))
        return 0
    header = f"{'name':<11} {'E (GPa)':>8} {'P (GPa)':>8} {'rho':>6} {'eps':>5} {'mu':>4} "
    header += f"{'max (mm)':>8} {'k (m/Ns)':>10} {'Y (Ns)':>7}"
    print(header)
    for name in library.names():
        m = library.materials[name]
        tag = "*" if m.k_explicit else " "
        print(
            f"{name:<11} {m.youngs_modulus / 1e9:8.3g} {m.plastic_modulus / 1e9:8.3g} "
            f"{m.density:6.0f} {m.restitution:5.2f} {m.friction:4.2f} "
            f"{m.max_dent_depth * 1e3:8.1f} "
            f"{m.k:10.3g}{tag}{m.Y:7.3g}"
        )
    print("(* k set by the preset; otherwise k = k_per_compliance * (1/P - 1/E))")
    return 0


def _cmd_info(args: argparse.Namespace) -> int:
    from dentdemo.gl.context import create_headless

    gl = create_headless(args.backend)
    print(f"GL backend:  {gl.backend}")
    print(f"GL renderer: {gl.renderer}")
    print(f"GL version:  {gl.version}")
    gl.release()
    from dentdemo.physics.ode import ode_configuration

    print(f"ODE config:  {ode_configuration()}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="dentdemo", description="Permanent dents from collisions, carved into bump maps."
    )
    parser.add_argument("--version", action="version", version=f"dentdemo {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("materials", help="list the effective material presets with k and Y")
    p.add_argument(
        "--materials",
        action="append",
        default=[],
        metavar="FILE",
        help="a TOML file that adds or overrides presets (repeatable)",
    )
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(handler=_cmd_materials)

    p = sub.add_parser("info", help="GL renderer of a headless context and ODE's configuration")
    p.add_argument("--backend", choices=("egl", "glx"), default=None)
    p.set_defaults(handler=_cmd_info)

    for register in _registrars():
        register(sub)
    return parser


def _registrars() -> list[Callable[[argparse._SubParsersAction], None]]:
    """Subcommands that live beside their layer register themselves here."""
    from dentdemo.app import commands

    return commands.REGISTRARS


def main(argv: Sequence[str] | None = None) -> int:
    try:
        parser = build_parser()
    except DentdemoError as exc:
        print(str(exc).splitlines()[0], file=sys.stderr)
        return 1
    args = parser.parse_args(argv)
    handler: Handler | None = getattr(args, "handler", None)
    if handler is None:
        parser.print_help()
        return 2
    try:
        return handler(args)
    except DentdemoError as exc:
        print(str(exc).splitlines()[0] if not _multiline_ok(exc) else str(exc), file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("dentdemo: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0


def _multiline_ok(exc: DentdemoError) -> bool:
    from dentdemo.errors import ShaderError

    return isinstance(exc, ShaderError)
