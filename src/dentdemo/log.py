"""Warnings to the user: one stderr line each, prefixed `dentdemo:`, silenced by --quiet. Python
warnings (ours and those of the libraries below us) and ODE's own messages all come here."""

from __future__ import annotations

import sys
import warnings

_state = {"quiet": False}


def warn(text: str) -> None:
    """One line on stderr (whitespace and newlines in `text` folded), unless quiet."""
    if _state["quiet"]:
        return
    line = " ".join(str(text).split())
    print(line if line.startswith("dentdemo:") else f"dentdemo: warning: {line}", file=sys.stderr)


def configure(quiet: bool) -> None:
    """Route Python warnings through `warn` and set --quiet."""
    _state["quiet"] = quiet

    def show(message, category, filename, lineno, file=None, line=None) -> None:  # noqa: ANN001
        warn(str(message))

    warnings.showwarning = show
    warnings.simplefilter("default")
    # A library's own source (pyrr's docstrings on Python 3.12, compiled where no .pyc was
    # written) is nothing a user can act on, and the line would not even name the file.
    warnings.filterwarnings("ignore", message="invalid escape sequence")
