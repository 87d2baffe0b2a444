"""Strict field checks for TOML tables; every error names file, table, key and value."""

from __future__ import annotations

import errno
import math
import os
import stat
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from dentdemo.errors import ConfigError

#: The largest TOML file read (scene, materials), bytes: the shipped ones are under 10 kB; 4 MiB
#: holds tens of thousands of bodies' tables and parses within a second or two.
TOML_MAX = 4 << 20

#: What each kind of node is called when an input is refused (only regular files are read).
_NODE_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISSOCK, "a socket"),
)


def not_regular(mode: int) -> str | None:
    """What a file of `mode` is when it is not a regular file (None when it is)."""
    if stat.S_ISREG(mode):
        return None
    return next((name for test, name in _NODE_KINDS if test(mode)), "not a regular file")


def read_input(path: Path, limit: int) -> bytes:
    """The bytes of the regular file `path` (a link is followed), at most `limit` of them.
    A device (/dev/zero), FIFO, socket or folder is refused without reading (a FIFO is never
    opened: it would block), and so is a larger file, each as an OSError whose strerror says
    why: no input is read without bound or blocks."""
    try:
        kind = not_regular(os.stat(path).st_mode)
    except OSError:
        kind = None  # missing or unreadable: open() below says which
    if kind is not None:
        raise OSError(errno.EINVAL, f"{kind}, not a regular file", str(path))
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY)
    with os.fdopen(fd, "rb") as handle:
        info = os.fstat(fd)
        kind = not_regular(info.st_mode)  # replaced since the stat above
        if kind is not None:
            raise OSError(errno.EINVAL, f"{kind}, not a regular file", str(path))
        data = handle.read(limit + 1)
    if len(data) > limit or info.st_size > limit:
        size = max(len(data), info.st_size)
        raise OSError(errno.EFBIG, f"{size} bytes, more than the {limit} read", str(path))
    return data


def load_toml(path: Path) -> dict[str, Any]:
    """Read a TOML file (a regular file of at most TOML_MAX bytes); I/O and syntax errors become
    a ConfigError naming the file."""
    try:
        return tomllib.loads(read_input(path, TOML_MAX).decode("utf-8"))
    except FileNotFoundError:
        raise ConfigError(str(path), "", "no such file") from None
    except OSError as exc:
        raise ConfigError(str(path), "", f"cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(
            str(path),
            "",
            f"not UTF-8 text (byte {exc.start}: {exc.object[exc.start : exc.start + 1]!r})",
        ) from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(str(path), "", f"malformed TOML: {exc}") from None


class TableReader:
    """Reads typed fields from one TOML table and reports unknown keys; `table_name` "" reads a
    file's top level."""

    def __init__(self, source: str, table_name: str, table: Any) -> None:
        if not isinstance(table, Mapping):
            where = f"[{table_name}]" if table_name else ""
            raise ConfigError(source, where, f"must be a table, got {_show(table)}")
        self.source = source
        self.table_name = table_name
        self.table = table
        self._used: set[str] = set()

    def fail(self, key: str, message: str) -> ConfigError:
        value = self.table.get(key, None)
        shown = f" = {_show(value)}" if key in self.table else ""
        return ConfigError(self.source, f"{self._where}key '{key}'{shown}", message)

    @property
    def _where(self) -> str:
        """'[table] ' for messages ('' for a file's top level, named by the file alone)."""
        return f"[{self.table_name}] " if self.table_name else ""

    def has(self, key: str) -> bool:
        return key in self.table

    def _present(self, key: str, default: object | None) -> bool:
        """Mark `key` as read; False when it is absent and has a default, raise when required."""
        self._used.add(key)
        if key in self.table:
            return True
        if default is None:
            raise ConfigError(self.source, self._where.strip(), f"missing key '{key}'")
        return False

    def number(
        self,
        key: str,
        default: float | None = None,
        *,
        min_value: float | None = None,
        max_value: float | None = None,
        min_inclusive: bool = True,
        max_inclusive: bool = True,
    ) -> float:
        if not self._present(key, default):
            return float(default)  # type: ignore[arg-type]  # _present raised when None
        value = self.table[key]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, "must be a number")
        value = _float(value)
        if not math.isfinite(value):
            raise self.fail(key, "must be finite")
        if min_value is not None and (
            value < min_value or (value == min_value and not min_inclusive)
        ):
            op = ">=" if min_inclusive else ">"
            raise self.fail(key, f"must be {op} {min_value:g}")
        if max_value is not None and (
            value > max_value or (value == max_value and not max_inclusive)
        ):
            op = "<=" if max_inclusive else "<"
            raise self.fail(key, f"must be {op} {max_value:g}")
        return value

    def positive(self, key: str, default: float | None = None) -> float:
        """A finite number > 0."""
        return self.number(key, default, min_value=0.0, min_inclusive=False)

    def vec3(
        self,
        key: str,
        default: Sequence[float] | None,
        max_norm: float | None = None,
        what: str = "",
    ) -> tuple[float, float, float]:
        """`vector` of three numbers, typed as such."""
        x, y, z = self.vector(key, default, 3, max_norm, what)
        return (x, y, z)

    def integer(
        self, key: str, default: int | None = None, *, min_value: int, max_value: int
    ) -> int:
        """A whole number in [min_value, max_value]; 2.5 or 2.0 are rejected, not truncated."""
        if not self._present(key, default):
            return int(default)  # type: ignore[arg-type]
        value = self.table[key]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(key, "must be an integer")
        if not min_value <= value <= max_value:
            raise self.fail(key, f"must lie in [{min_value}, {max_value}]")
        return value

    def vector(
        self,
        key: str,
        default: Sequence[float] | None,
        length: int = 3,
        max_norm: float | None = None,
        what: str = "",
    ) -> tuple[float, ...]:
        """A list of `length` finite numbers; with `max_norm`, its length is bounded (`what` names
        the quantity and unit in the message)."""
        if not self._present(key, default):
            return tuple(float(x) for x in default or ())
        value = self.table[key]
        if not isinstance(value, list) or len(value) != length:
            raise self.fail(key, f"must be a list of {length} numbers")
        out = []
        for item in value:
            if isinstance(item, bool) or not isinstance(item, int | float):
                raise self.fail(key, f"must be a list of {length} numbers")
            if not math.isfinite(_float(item)):
                raise self.fail(key, "must contain finite numbers only")
            out.append(float(item))
        if max_norm is not None and math.hypot(*out) > max_norm:
            raise self.fail(key, f"{what or 'length'} must be <= {max_norm:g} (plausibility bound)")
        return tuple(out)

    def string(self, key: str, default: str | None = None, choices: Sequence[str] = ()) -> str:
        if not self._present(key, default):
            return str(default)
        value = self.table[key]
        if not isinstance(value, str):
            raise self.fail(key, "must be a string")
        if choices and value not in choices:
            raise self.fail(key, f"must be one of {', '.join(choices)}")
        return value

    def boolean(self, key: str, default: bool) -> bool:
        if not self._present(key, default):
            return default
        value = self.table[key]
        if not isinstance(value, bool):
            raise self.fail(key, "must be true or false")
        return value

    def raw(self, key: str) -> Any:
        """A required key's value as it is (a nested table or list the caller reads)."""
        self._present(key, None)
        return self.table[key]

    def table_at(self, key: str) -> TableReader:
        """A required nested table, read by a reader of its own (`[outer.key]` in messages)."""
        name = f"{self.table_name}.{key}" if self.table_name else key
        return TableReader(self.source, name, self.raw(key))

    def items(self, key: str, max_length: int) -> list[Any]:
        """A required list of at most `max_length` entries, each read by the caller."""
        value = self.raw(key)
        if not isinstance(value, list):
            raise self.fail(key, "must be a list")
        if len(value) > max_length:
            raise self.fail(key, f"must hold at most {max_length} entries, holds {len(value)}")
        return value

    def finish(self) -> None:
        """Raise on the first key that no reader asked for."""
        for key in self.table:
            if key not in self._used:
                raise self.fail(key, "unknown key")


def _float(value: int | float) -> float:
    """A number as a float; an integer beyond float range (JSON has no limit) is infinite."""
    try:
        return float(value)
    except OverflowError:
        return math.inf


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."
