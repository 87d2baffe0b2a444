"""The GL library of the current context, for the few calls moderngl does not make (reading
and restoring host state, glFlush)."""

from __future__ import annotations

import ctypes
import ctypes.util
from functools import cache

#: The glIs* calls dentdemo makes (they return a GLboolean, one byte).
_BOOLEAN_QUERIES = (
    "Enabled",
    "Framebuffer",
    "Program",
    "VertexArray",
    "Buffer",
    "Texture",
    "Sampler",
)


@cache
def gl_library() -> ctypes.CDLL:
    """The GL entry points of the current context (glvnd's libOpenGL, else libGL)."""
    for name in ("libOpenGL.so.0", "libGL.so.1", ctypes.util.find_library("GL")):
        if name:
            try:
                gl = ctypes.CDLL(name)
            except OSError:
                continue
            for query in _BOOLEAN_QUERIES:
                getattr(gl, f"glIs{query}").restype = ctypes.c_ubyte  # GLboolean
            return gl
    raise OSError("no OpenGL library (libOpenGL.so.0 or libGL.so.1) to call")


def flush() -> None:
    """Start the work queued so far (glFlush) without waiting for it: a software rasteriser
    then draws while the caller goes on with CPU work."""
    gl_library().glFlush()
