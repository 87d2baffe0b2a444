"""`dentdemo info`: the GL renderer of a headless context and ODE's build configuration."""

from __future__ import annotations

import argparse

from dentdemo.cli.args import add_backend, command


def register(sub: argparse._SubParsersAction) -> None:
    p = command(
        sub,
        "info",
        "show the GL renderer of a headless context and ODE's configuration",
        "dentdemo info --backend egl",
    )
    add_backend(p)
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from dentdemo.gl.context import create_headless
    from dentdemo.render.displacement import describe
    from dentdemo.render.quality import preset

    gl = create_headless(args.backend)
    print(f"GL backend:  {gl.backend}")
    print(f"GL renderer: {gl.renderer}")
    print(f"GL version:  {gl.version}")
    quality = preset(None, gl.software)
    why = "software rasteriser" if gl.software else "GPU"
    print(f"Quality:     {quality.name} by default ({why}); --quality low|medium|high")
    print(f"Displacement: {describe(gl.ctx)}")
    gl.release()
    from dentdemo.physics.ode import ode_configuration

    print(f"ODE config:  {ode_configuration()}")
    return 0
