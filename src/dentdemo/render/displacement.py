"""Which way the renderer moves surfaces by their height maps, chosen at run time: `tessellation`
(GL 4.0: render/displace.tesc cuts a body's triangles where its dents are deep, adaptively) or
`mesh` (a finer render mesh, render/refine.py, moved vertex by vertex; for GL 3.3). The variable
DENTDEMO_DISPLACEMENT=tessellation|mesh forces one; `dentdemo info` shows the choice."""

from __future__ import annotations

import os

import moderngl

from dentdemo.errors import DentdemoError

ENV = "DENTDEMO_DISPLACEMENT"
PATHS = ("tessellation", "mesh")
#: GL version code (major * 100 + minor * 10) with tessellation shaders.
TESSELLATION_GL = 400


def displacement_path(ctx: moderngl.Context, forced: str | None = None) -> str:
    """`forced` (or the environment's DENTDEMO_DISPLACEMENT), else tessellation where the context
    has it and the finer mesh elsewhere."""
    where = "displacement" if forced is not None else ENV
    choice = forced if forced is not None else os.environ.get(ENV, "").strip()
    if choice and choice not in PATHS:
        raise DentdemoError(f"{where}: unknown path {choice!r} (known: {', '.join(PATHS)})")
    if choice == "tessellation" and ctx.version_code < TESSELLATION_GL:
        raise DentdemoError(
            f"{where}=tessellation: this context is GL {ctx.version_code // 100}."
            f"{ctx.version_code // 10 % 10}; tessellation needs 4.0"
        )
    return choice or ("tessellation" if ctx.version_code >= TESSELLATION_GL else "mesh")


def describe(ctx: moderngl.Context) -> str:
    """One line for `dentdemo info`: the path and why."""
    path = displacement_path(ctx)
    version = f"GL {ctx.version_code // 100}.{ctx.version_code // 10 % 10}"
    if os.environ.get(ENV, "").strip():
        return f"{path} (forced by {ENV}={path}; {version})"
    if path == "mesh":
        return (
            f"mesh, a finer render mesh ({version} has no tessellation; the low preset moves "
            "the mesh's own vertices)"
        )
    return (
        f"tessellation ({version}; the low preset moves the mesh's own vertices); "
        f"{ENV}=mesh forces the finer-mesh fallback"
    )
