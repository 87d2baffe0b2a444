"""Counting the GL calls a piece of work makes (the bench's `gl_calls_per_batch`).

A call is one method call or property write on a moderngl object (context, program, uniform,
vertex array, framebuffer, texture, buffer, sampler, query): each reaches the driver once or a
few times (a vertex array's render binds its program and array, then draws); plus each raw GL
entry point called through `gl.library.gl_library()` (state moderngl does not set, glFlush).
A uniform write counts once (`gl.shaders`' writers call `Uniform.write`). The wrappers go on
the classes while `counting` is open; objects that kept a bound method from before (a
program's uniform writers) call past them, so the context whose calls are counted is made
inside it."""

from __future__ import annotations

import contextlib
import ctypes
from collections.abc import Callable, Iterator
from typing import Any

import moderngl

from dentdemo.gl.library import gl_library

_CLASSES = (
    moderngl.Context,
    moderngl.Program,
    moderngl.Uniform,
    moderngl.VertexArray,
    moderngl.Framebuffer,
    moderngl.Texture,
    moderngl.Buffer,
    moderngl.Sampler,
    moderngl.Query,
)
#: Methods that only read what moderngl keeps on the Python side (no GL call).
_QUIET = frozenset({"get", "__enter__", "__exit__"})


class GLCalls:
    """The number of GL calls made since `reset` while `counting` is open."""

    def __init__(self) -> None:
        self.count = 0

    def reset(self) -> None:
        self.count = 0


def _counted(calls: GLCalls, function: Callable[..., Any]) -> Callable[..., Any]:
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        calls.count += 1
        return function(*args, **kwargs)

    return wrapper


@contextlib.contextmanager
def counting() -> Iterator[GLCalls]:
    """Count the GL calls made inside (see the module's note): moderngl's methods and property
    writes, and the raw entry points of `gl_library()`."""
    calls = GLCalls()
    patched: list[tuple[type, str, object]] = []
    for cls in _CLASSES:
        for name, member in list(vars(cls).items()):
            if name in _QUIET or (name.startswith("__") and name != "__setitem__"):
                continue
            if isinstance(member, property) and member.fset is not None:
                wrapped: object = property(member.fget, _counted(calls, member.fset), member.fdel)
            elif callable(member) and not isinstance(member, type):
                wrapped = _counted(calls, member)
            else:
                continue
            patched.append((cls, name, member))
            setattr(cls, name, wrapped)
    library = gl_library()
    plain = type(library)

    class Counted(plain):  # type: ignore[valid-type, misc]
        def __getattribute__(self, name: str) -> Any:
            if name.startswith("gl"):
                calls.count += 1
            return ctypes.CDLL.__getattribute__(self, name)

    library.__class__ = Counted
    try:
        yield calls
    finally:
        library.__class__ = plain
        for owner, name, member in reversed(patched):
            setattr(owner, name, member)
