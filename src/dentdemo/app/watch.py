"""Files watched while the demo runs: polled (no new dependency, no thread), a change reported
once its content has settled.

A file's content is hashed at each poll (materials and scene files are a few kB). Only a regular
file of at most TOML_MAX bytes is read: a FIFO would block the frame loop and /dev/zero never
ends, so anything else is fingerprinted by what it is (and a larger file by its size and time),
without opening it; the reload then says what is wrong with it. A new content
is reported when two polls at least `interval` seconds apart both saw it, so an editor's save in
several writes is read once, whole. A file that cannot be read (mid-rename, deleted) counts as a
content of its own: it is reported too, and the reader says what is wrong with it.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

from dentdemo.model.validate import TOML_MAX, read_input

#: Seconds between two polls of the files (two polls settle a change: within a second).
POLL_INTERVAL = 0.2


def fingerprint(path: Path) -> str:
    """The SHA-256 of the file's bytes, or 'unreadable: WHY' when it cannot be read (a FIFO,
    a device, a file over TOML_MAX bytes: never opened or read past the bound)."""
    try:
        return hashlib.sha256(read_input(path, TOML_MAX)).hexdigest()
    except OSError as exc:
        try:
            info = path.stat()
            when = f" {info.st_size} {info.st_mtime_ns}"
        except OSError:
            when = ""
        return f"unreadable: {exc.strerror or exc}{when}"


@dataclass
class FileWatcher:
    """Polls `paths`; `poll(now)` returns those whose content changed and settled since the
    content last reported (or seen at start)."""

    paths: tuple[Path, ...]
    interval: float = POLL_INTERVAL
    #: The content last reported (or read at start) per file.
    _known: dict[Path, str] = field(default_factory=dict)
    #: The content the previous poll saw per file.
    _seen: dict[Path, str] = field(default_factory=dict)
    _polled_at: float | None = None

    def __post_init__(self) -> None:
        for path in self.paths:
            self._known[path] = self._seen[path] = fingerprint(path)

    def poll(self, now: float) -> list[Path]:
        """The files whose new content two polls have seen (`now`: seconds, any monotonic
        clock). A call sooner than `interval` after the last poll does nothing."""
        if self._polled_at is not None and now - self._polled_at < self.interval:
            return []
        self._polled_at = now
        changed = []
        for path in self.paths:
            current = fingerprint(path)
            settled = current == self._seen[path]
            self._seen[path] = current
            if settled and current != self._known[path]:
                self._known[path] = current
                changed.append(path)
        return changed
