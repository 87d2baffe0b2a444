"""The one exception type the CLI turns into a one-line message and a non-zero exit."""

from __future__ import annotations


class DentdemoError(Exception):
    """A user-facing error: its message is one line that names the file, key or library at fault."""


class ConfigError(DentdemoError):
    """Bad input in a TOML file or on the command line."""

    def __init__(self, source: str, where: str, message: str) -> None:
        self.source = source
        self.where = where
        text = f"{source}: {where}: {message}" if where else f"{source}: {message}"
        super().__init__(text)


class ArgumentError(DentdemoError, ValueError):
    """A library call got a bad argument; the message names the argument and its value. A
    ValueError for a host program (the one class every bad argument of the public API raises),
    a one-line message for the CLI."""


class MissingFileError(ArgumentError, FileNotFoundError):
    """A file argument names no file: a ValueError like every bad argument, and a
    FileNotFoundError (OSError) for a host that catches those for files."""


class ContextError(DentdemoError, RuntimeError):
    """A library call was made where the GL context of its objects is not current: another
    context is current, or none is in the calling thread. Nothing was done."""


class UndoWarning(UserWarning):
    """A call's undo snapshots alone exceed the undo budget: that call is carved but cannot be
    undone (the history before it is kept)."""


class GLUnavailableError(DentdemoError):
    """No OpenGL 3.3 core context could be made."""


class ShaderError(DentdemoError):
    """A shader failed to load, compile or link; the message names file and line."""


class MissingExtraError(DentdemoError):
    """An optional dependency (the `app` extra: window, panel, video) is not installed."""


class PhysicsLibraryError(DentdemoError):
    """The ODE library or one of the symbols we use is missing."""
