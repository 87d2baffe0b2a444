"""Helpers shared by the tests that count what a piece of work asks of GL directly."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from dentdemo.gl.library import gl_library


@contextmanager
def raw_gl_calls(*names: str) -> Iterator[list[tuple[str, tuple[int, ...]]]]:
    """Each call of the raw GL entry points `names` made through `gl_library()` while open, as
    (name, arguments as ints), in order. Each is looked up once first: ctypes keeps a function
    on the library after its first lookup, and that first lookup would pass by the recording."""
    library = gl_library()
    plain = type(library)
    for name in names:
        getattr(library, name)
    calls: list[tuple[str, tuple[int, ...]]] = []

    class Recording(plain):  # type: ignore[valid-type, misc]
        def __getattribute__(self, name: str):  # noqa: ANN204
            function = plain.__getattribute__(self, name)
            if name not in names:
                return function

            def recorded(*args: int):  # noqa: ANN202
                calls.append((name, tuple(int(arg) for arg in args)))
                return function(*args)

            return recorded

    library.__class__ = Recording
    try:
        yield calls
    finally:
        library.__class__ = plain
