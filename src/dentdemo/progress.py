"""Progress bars (tqdm) on stderr when it is a terminal, and silence when it is not (a pipe, a log
file, the tests)."""

from __future__ import annotations

import shutil
import sys
from typing import Any


def progress_bar(total: int | None, unit: str) -> Any:
    """A tqdm bar counting `unit`s, or None when stderr is not a terminal."""
    if not sys.stderr.isatty():
        return None
    from tqdm import tqdm

    # A bare pseudo-terminal reports 0 x 0, and tqdm hides bars below the last row.
    columns, rows = shutil.get_terminal_size(fallback=(80, 24))
    return tqdm(
        total=total,
        unit=f" {unit}",
        leave=False,
        ncols=columns or 80,
        nrows=rows or 24,
        file=sys.stderr,
    )
