"""Progress bars (tqdm) on stderr when it is a terminal, and silence when it is not (a pipe, a log
file, the tests) or when tqdm (the `app` extra) is not installed."""

from __future__ import annotations

import shutil
import sys
from typing import Any


def progress_bar(total: int | None, unit: str) -> Any:
    """A tqdm bar counting `unit`s, or None when stderr is not a terminal or tqdm is missing."""
    if not sys.stderr.isatty():
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # the library install without the app extra: no bar, no message
        return None

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
