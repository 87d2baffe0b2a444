"""Subcommands beyond `materials` and `info`; each adds its parser to REGISTRARS."""

from __future__ import annotations

import argparse
from collections.abc import Callable

REGISTRARS: list[Callable[[argparse._SubParsersAction], None]] = []
