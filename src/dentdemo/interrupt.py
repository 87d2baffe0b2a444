"""Ctrl-C, honoured at safe points. Python's default handler raises KeyboardInterrupt wherever the
main thread happens to be, and there it can be swallowed (inside a finaliser, a ctypes callback)
and print a traceback. Here SIGINT only marks the request; the loops of every command call
`check()` once per frame, step or press, which raises KeyboardInterrupt there. A second Ctrl-C
raises at once."""

from __future__ import annotations

import signal
from types import FrameType

_state = {"requested": False}


def _on_sigint(signum: int, frame: FrameType | None) -> None:
    if _state["requested"]:
        raise KeyboardInterrupt
    _state["requested"] = True


def install() -> None:
    """Route SIGINT here (the command line does, at start)."""
    _state["requested"] = False
    signal.signal(signal.SIGINT, _on_sigint)


def check() -> None:
    """Raise KeyboardInterrupt if Ctrl-C was pressed since `install`."""
    if _state["requested"]:
        _state["requested"] = False
        raise KeyboardInterrupt
