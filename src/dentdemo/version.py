"""The package's version, read from its installed metadata (pyproject.toml's `[project]` version),
so that it is written in one place."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    VERSION = version("dentdemo")
except PackageNotFoundError:  # a source tree on sys.path that was never installed
    VERSION = "0+unknown"
