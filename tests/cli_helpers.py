"""Running the installed `dentdemo` command (as `python -m dentdemo`) from tests."""

from __future__ import annotations

import subprocess
import sys


def dentdemo(*args: object, **kwargs) -> subprocess.CompletedProcess:
    """Run `python -m dentdemo ARGS`, capturing text output; kwargs go to subprocess.run."""
    command = [sys.executable, "-m", "dentdemo", *(str(a) for a in args)]
    return subprocess.run(command, capture_output=True, text=True, **kwargs)
