"""The optional `app` extra: the window (glfw), the panel (imgui-bundle), video (imageio-ffmpeg),
progress bars (tqdm) and the material editor's saving (tomlkit). `pip install dentdemo` leaves
them out; the library (carve, meshes, model, physics, headless rendering) never imports them,
and what needs one asks here first, so that a missing one is a single line naming the extra to
install."""

from __future__ import annotations

import importlib.util

from dentdemo.errors import MissingExtraError

#: The extra that carries the demo's weight.
APP_EXTRA = "app"
#: Import name -> the package `pip install dentdemo[app]` brings for it.
APP_PACKAGES = {
    "glfw": "glfw",
    "imgui_bundle": "imgui-bundle",
    "imageio_ffmpeg": "imageio-ffmpeg",
    "tqdm": "tqdm",
    "tomlkit": "tomlkit",
}


def installed(module: str) -> bool:
    """Whether `module` can be imported (found on the path; not imported here)."""
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def require_app(purpose: str, *modules: str) -> None:
    """Raise MissingExtraError, naming the extra, unless every one of `modules` (keys of
    APP_PACKAGES) is installed; `purpose` says what needs them ("the interactive demo")."""
    missing = [APP_PACKAGES[m] for m in modules if not installed(m)]
    if missing:
        raise MissingExtraError(
            f"dentdemo: {purpose} needs {' and '.join(missing)}, from the '{APP_EXTRA}' extra: "
            f"pip install 'dentdemo[{APP_EXTRA}]'"
        )
