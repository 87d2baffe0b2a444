"""The one place that makes OpenGL contexts: headless (EGL) or windowed (glfw), 3.3 core or better.

The backend comes from the caller, else from $DENTDEMO_GL_BACKEND (`egl` for headless through EGL,
`glx` for a standalone X11 context). Every GPU->CPU read in dentdemo goes through `GLContext.read`,
which counts reads, so tests can prove that the simulation/carve/render loop reads nothing back.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import threading
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import moderngl
import numpy as np

from dentdemo.errors import ContextError, GLUnavailableError

REQUIRED_VERSION = 330
#: Asked for first by a headless context: EGL on NVIDIA's driver gives exactly the version asked
#: for (3.3: no tessellation, so the renderer's displacement falls back to finer meshes), where
#: Mesa gives its highest either way. A driver without it gets REQUIRED_VERSION.
PREFERRED_VERSION = 450
HEADLESS_BACKENDS = ("egl", "glx")
#: glcontext's names for them: its default on Linux (no name) is a GLX context on an X display.
_GLCONTEXT_BACKEND: dict[str, str | None] = {"egl": "egl", "glx": None}
#: What to install for each way of making a context (Debian packages).
_INSTALL_HINTS = {
    "egl": "install an OpenGL 3.3 driver with EGL (Debian: apt-get install libegl1 libegl-mesa0 "
    "libgl1-mesa-dri)",
    "glx": "run under an X display (Xvfb works) with an OpenGL 3.3 driver with GLX (Debian: "
    "apt-get install libgl1 libglx-mesa0 libgl1-mesa-dri)",
    "glfw": "run under an X display with an OpenGL 3.3 driver (Debian: apt-get install libgl1 "
    "libglx-mesa0 libgl1-mesa-dri)",
}


@dataclass
class GLContext:
    """A moderngl context plus what dentdemo needs beside it."""

    ctx: moderngl.Context
    backend: str
    #: The glfw window for a windowed context, else None.
    window: Any = None
    #: Number of GPU->CPU reads made through `read` since creation (or the last reset).
    reads: int = 0
    #: Per-context caches (shader programs, meshes on the GPU) keyed by their owners.
    cache: dict[str, Any] = field(default_factory=dict)

    @property
    def renderer(self) -> str:
        return str(self.ctx.info.get("GL_RENDERER", "?"))

    @property
    def software(self) -> bool:
        """True on a software rasteriser (Mesa llvmpipe, softpipe, swrast; SwiftShader), where
        vertices are shaded on the CPU beside the application."""
        name = self.renderer.lower()
        return any(word in name for word in ("llvmpipe", "softpipe", "swrast", "swiftshader"))

    @property
    def version(self) -> str:
        return str(self.ctx.info.get("GL_VERSION", "?"))

    def read(self, texture: moderngl.Texture, components: int | None = None) -> np.ndarray:
        """Read a float texture back to the CPU as float32 [rows = v, cols = u, components].

        For export, screenshots, benchmarks and tests only: never inside the frame loop.
        """
        self.reads += 1
        self.settle()
        comps = components or texture.components
        dtype = {"f4": np.float32, "f2": np.float16, "f1": np.uint8, "u1": np.uint8}[texture.dtype]
        data = np.frombuffer(texture.read(), dtype=dtype)
        data = data.reshape(texture.height, texture.width, texture.components)
        return np.array(data[:, :, :comps], dtype=np.float32 if dtype != np.uint8 else np.uint8)

    def read_region(
        self,
        fbo: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int],
        components: int,
        attachment: int = 0,
    ) -> np.ndarray:
        """Read a rectangle (x, y, width, height) of a float attachment (-1: the depth buffer) as
        float32 [rows, cols, components]. CPU reference path of the benchmark and tests only."""
        self.reads += 1
        self.settle()
        x, y, w, h = viewport
        raw = fbo.read(viewport=viewport, components=components, attachment=attachment, dtype="f4")
        return np.frombuffer(raw, dtype=np.float32).reshape(h, w, components)

    def read_framebuffer(self, fbo: moderngl.Framebuffer, components: int = 3) -> np.ndarray:
        """Read an 8-bit colour framebuffer as uint8 [rows from the bottom, cols, components]."""
        self.reads += 1
        self.settle()
        raw = fbo.read(components=components, alignment=1)
        return np.frombuffer(raw, dtype=np.uint8).reshape(fbo.height, fbo.width, components)

    def settle(self) -> None:
        """glFinish before a read back: Mesa 22.3's llvmpipe sometimes returned a map as it was
        before the draws just issued into it (a read straight after a carve found no dent in
        about 1 of 6 runs of tests/test_carve_batch.py; after glFinish the dent was there).
        Reads are for exports, benchmarks and tests, never in the frame loop."""
        self.ctx.finish()

    def __post_init__(self) -> None:
        owner(self.ctx)  # the context is current where it is made or first met

    def check_current(self, what: str) -> None:
        """Raise ContextError (naming `what`) unless this context is current in this thread."""
        check_current(self.ctx, what)

    def make_current(self) -> None:
        """Make this context current again (after another context in the process was made or
        released: EGL has one current context per thread)."""
        if self.window is not None:
            import glfw

            glfw.make_context_current(self.window)
        else:
            self.ctx.__enter__()

    def check_error(self, where: str) -> None:
        """Raise if OpenGL has a pending error."""
        err = self.ctx.error
        if err != "GL_NO_ERROR":
            raise RuntimeError(f"OpenGL error after {where}: {err}")

    def release(self) -> None:
        self.cache.clear()
        self.ctx.release()
        if self.window is not None:
            import glfw

            glfw.destroy_window(self.window)
            self.window = None


def release(*objects: Any) -> None:
    """Release moderngl objects, first moving off a framebuffer that is about to go: moderngl
    re-binds the current framebuffer whenever it makes a new one, and a released one is an invalid
    name (GL_INVALID_OPERATION). Headless contexts have no default framebuffer to fall back to, so
    a 1x1 parking framebuffer is kept per context."""
    for obj in objects:
        if obj is None:
            continue
        ctx = getattr(obj, "ctx", None)
        if ctx is not None and ctx.fbo is obj:
            parking_framebuffer(ctx).use()
        obj.release()


def parking_framebuffer(ctx: moderngl.Context) -> moderngl.Framebuffer:
    """A framebuffer that lives as long as the context (the screen's, where there is one)."""
    if ctx.screen is not None:
        return ctx.screen
    store = per_context(ctx)
    if "parking_fbo" not in store:
        store["parking_fbo"] = ctx.framebuffer([ctx.renderbuffer((1, 1))])
    return store["parking_fbo"]


@dataclass(frozen=True)
class Owner:
    """Where a moderngl context lives: its native handle (what `current_native` gave while it
    was current) and the thread it was made or first met in (its name, for messages, and its
    identity)."""

    native: tuple[str, int] | None
    thread: str
    thread_id: int


#: What `current_native` gives where dentdemo cannot ask which context is current (neither EGL
#: nor GLX: Windows, macOS): no check is made there.
UNSEEN = ("unseen", 0)


@cache
def _current_queries() -> tuple[tuple[str, Any], ...]:
    """(API, its get-current-context function) for EGL and GLX, those this system has."""
    found = []
    for api, library, function in (
        ("egl", "EGL", "eglGetCurrentContext"),
        ("glx", "GL", "glXGetCurrentContext"),
    ):
        name = ctypes.util.find_library(library)
        try:
            query = getattr(ctypes.CDLL(name), function) if name else None
        except (OSError, AttributeError):
            query = None
        if query is not None:
            query.restype = ctypes.c_void_p
            query.argtypes = []
            found.append((api, query))
    return tuple(found)


def current_native() -> tuple[str, int] | None:
    """The context current in this thread, as (API, native handle); None when none is;
    UNSEEN where there is no way to ask."""
    queries = _current_queries()
    if not queries:
        return UNSEEN
    for api, query in queries:
        handle = query()
        if handle:
            return (api, handle)
    return None


def owner(ctx: moderngl.Context) -> Owner:
    """Where `ctx` lives, recorded the first time dentdemo meets it (a context is current
    when it is made, and a host's must be when it first passes it: moderngl makes its objects
    in whichever context is current). ContextError when none is current then."""
    store = per_context(ctx)
    if "owner" not in store:
        native = current_native()
        if native is None:
            raise ContextError(_none_current("dentdemo", None))
        here = threading.current_thread()
        store["owner"] = Owner(native, here.name, threading.get_ident())
    return store["owner"]


def check_current(ctx: moderngl.Context, what: str) -> None:
    """Raise ContextError, naming `what` (the call), unless `ctx` is the context current in
    this thread. dentdemo never makes a context current itself: a host gets back exactly the
    current context it had, and its objects are never written through another's names."""
    home = owner(ctx)
    native = current_native()
    if native == home.native or home.native == UNSEEN:
        return
    if native is None:
        raise ContextError(_none_current(what, home))
    if threading.get_ident() != home.thread_id:
        raise ContextError(
            f"{what}: thread {threading.current_thread().name!r} has another GL context "
            f"current: call dentdemo from the thread where its GL context is current (thread "
            f"{home.thread!r} made it); nothing was done"
        )
    raise ContextError(
        f"{what}: another GL context is current, not the one these objects were made in; "
        "make that one current first (dentdemo never switches contexts); nothing was done"
    )


def _none_current(what: str, home: Owner | None) -> str:
    """The message for a call made in a thread where no GL context is current."""
    made = f" (thread {home.thread!r} made its context)" if home is not None else ""
    return (
        f"{what}: no GL context is current in thread {threading.current_thread().name!r}: "
        f"call dentdemo from the thread where its GL context is current{made}; nothing was done"
    )


#: The attribute of a moderngl.Context that holds `per_context`'s dict.
_STORE = "_dentdemo"


def per_context(ctx: moderngl.Context) -> dict[str, Any]:
    """dentdemo's objects for one moderngl context (its wrapper of a host's context, the parking
    framebuffer). They are kept on the context object under a private attribute, never in
    `ctx.extra` (the host's own), so they live exactly as long as the context: a module-level
    table, even a weakref.WeakKeyDictionary, would keep every context alive, since the objects
    it holds (programs, framebuffers, the wrapper) all refer back to their context."""
    store = vars(ctx).get(_STORE)
    if store is None:
        store = {}
        setattr(ctx, _STORE, store)
    return store


def headless_backend(requested: str | None = None) -> str:
    backend = (requested or os.environ.get("DENTDEMO_GL_BACKEND") or "egl").lower()
    if backend not in HEADLESS_BACKENDS:
        raise GLUnavailableError(
            f"dentdemo: unknown GL backend '{backend}' (DENTDEMO_GL_BACKEND must be one of "
            f"{', '.join(HEADLESS_BACKENDS)})"
        )
    return backend


def create_headless(backend: str | None = None) -> GLContext:
    """A standalone context with no window (EGL by default: Mesa llvmpipe where there is no GPU)."""
    name = headless_backend(backend)
    try:
        if name == "glx" and not os.environ.get("DISPLAY"):
            raise RuntimeError("GLX needs an X display and DISPLAY is not set")
        backend = _GLCONTEXT_BACKEND[name]
        settings: Any = {} if backend is None else {"backend": backend}  # stubs type it loosely
        try:
            ctx = moderngl.create_context(standalone=True, require=PREFERRED_VERSION, **settings)
        except Exception:  # noqa: BLE001 (glcontext raises plain exceptions): 3.3 will do
            ctx = moderngl.create_context(standalone=True, require=REQUIRED_VERSION, **settings)
    except Exception as exc:  # moderngl raises plain Exception subclasses from glcontext
        detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise GLUnavailableError(
            f"dentdemo: no OpenGL 3.3 core context through {name.upper()} ({detail}); "
            f"{_INSTALL_HINTS[name]}"
        ) from None
    return _checked(GLContext(ctx=ctx, backend=name))


def has_display() -> bool:
    """Whether a window can be opened at all: an X (DISPLAY) or Wayland display is named."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def create_window(width: int, height: int, title: str, *, visible: bool = True) -> GLContext:
    """A glfw window with an OpenGL 3.3 core context (forward compatible, as macOS requires).
    Its framebuffer only receives finished images (the renderer does its own multisampling and
    depth test offscreen), so it has neither samples nor depth: on a software rasteriser a 4x
    multisampled window made every touch of the screen, swap included, cost a resolve."""
    import glfw

    if not has_display():
        raise GLUnavailableError("dentdemo: no display (DISPLAY is not set); cannot open a window")
    if not glfw.init():
        raise GLUnavailableError("dentdemo: glfw could not initialise the display " + _glfw_error())
    glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
    glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
    glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
    glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
    glfw.window_hint(glfw.VISIBLE, visible)
    glfw.window_hint(glfw.SAMPLES, 0)
    glfw.window_hint(glfw.DEPTH_BITS, 0)
    glfw.window_hint(glfw.STENCIL_BITS, 0)
    window = glfw.create_window(width, height, title, None, None)
    if not window:
        raise GLUnavailableError(
            "dentdemo: glfw could not open an OpenGL 3.3 core window " + _glfw_error()
        )
    glfw.make_context_current(window)
    glfw.swap_interval(0)
    try:
        ctx = moderngl.create_context(require=REQUIRED_VERSION)
    except Exception as exc:
        glfw.destroy_window(window)
        raise GLUnavailableError(
            f"dentdemo: window context below OpenGL 3.3 core ({exc})"
        ) from None
    return _checked(GLContext(ctx=ctx, backend="glfw", window=window))


def _glfw_error() -> str:
    import glfw

    code, text = glfw.get_error()
    if text:
        return f"({text.decode() if isinstance(text, bytes) else text})"
    return "" if not code else f"(glfw error {code})"


def _checked(gl: GLContext) -> GLContext:
    if gl.ctx.version_code < REQUIRED_VERSION:
        found = gl.ctx.version_code
        gl.release()
        raise GLUnavailableError(
            f"dentdemo: OpenGL {found} found, 330 core required; "
            f"{_INSTALL_HINTS.get(gl.backend, _INSTALL_HINTS['egl'])}"
        )
    return gl
