"""The demo's status line: the outcome of the last action (a save, load, export, reload, record,
undo), one line for the panel and the window's title."""

from __future__ import annotations

import sys
from collections.abc import Callable

from dentdemo import log
from dentdemo.errors import DentdemoError


class Status:
    """One line, written by every feature controller."""

    def __init__(self) -> None:
        self.line = ""

    def say(self, line: str) -> str:
        self.line = line
        return line

    def report(self, line: str) -> str:
        """An outcome the terminal sees too: one stderr line (silenced by --quiet)."""
        log.warn(line)
        return self.say(line)

    def error(self, exc: DentdemoError) -> str:
        """A failed action: the error's first line on stderr and in the panel."""
        line = str(exc).splitlines()[0]
        print(line, file=sys.stderr)
        return self.say(line)

    def attempt(self, action: Callable[[], object], done: Callable[[], str]) -> bool:
        """Run a save, load or export: `done()`'s line, or the error's text, becomes the
        line."""
        try:
            action()
        except DentdemoError as exc:
            self.line = str(exc)
            return False
        self.line = done()
        return True
