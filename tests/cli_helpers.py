"""Running the installed `dentdemo` command (as `python -m dentdemo`) from tests."""

from __future__ import annotations

import subprocess
import sys


def dentdemo(*args: object, **kwargs) -> subprocess.CompletedProcess:
    """Run `python -m dentdemo ARGS`, capturing text output; kwargs go to subprocess.run."""
    command = [sys.executable, "-m", "dentdemo", *(str(a) for a in args)]
    return subprocess.run(command, capture_output=True, text=True, **kwargs)


def python_json(code: str, *args: object, env: dict | None = None, timeout: float = 300) -> object:
    """Run `python -c CODE ARGS` (a window test's script, under Xvfb by `env`) and return the JSON
    of its last stdout line; a failed run fails the test with its stderr."""
    result = subprocess.run(
        [sys.executable, "-c", code, *(str(a) for a in args)],
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert result.returncode == 0, result.stderr
    import json

    return json.loads(result.stdout.strip().splitlines()[-1])
