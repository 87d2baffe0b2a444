"""Subcommands beyond `materials` and `info`; each module's `register` adds its parser."""

from __future__ import annotations

import argparse
from collections.abc import Callable

from dentdemo.app import demo, headless, indent
from dentdemo.bench import run as bench
from dentdemo.physics import simulate

REGISTRARS: list[Callable[[argparse._SubParsersAction], None]] = [
    indent.register,
    simulate.register,
    headless.register,
    demo.register,
    bench.register,
]
