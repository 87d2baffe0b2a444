"""Where the shipped shaders and assets live: in a source checkout or in an installed wheel."""

from __future__ import annotations

from pathlib import Path

from dentdemo.errors import DentdemoError

_PACKAGE_DIR = Path(__file__).resolve().parent


def data_dir(name: str) -> Path:
    """Return the folder `shaders` or `assets`.

    In a wheel they are installed inside the package (dentdemo/shaders); in a source checkout
    they sit at the repository root next to src/.
    """
    for candidate in (_PACKAGE_DIR / name, _PACKAGE_DIR.parents[1] / name):
        if candidate.is_dir():
            return candidate
    raise DentdemoError(f"dentdemo: the '{name}' folder is missing from the installation")


def shaders_dir() -> Path:
    return data_dir("shaders")


def assets_dir() -> Path:
    return data_dir("assets")
