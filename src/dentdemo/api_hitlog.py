"""The hit log of a host program's Carver (`Carver.log_to`): its presses as records, named by the
host's names for its surfaces (`dentdemo.replay` carves them elsewhere). Below api.py: it knows
a surface only by what api.py's DentableSurface shows (`model`, `map_size`, `max_dent_depth`);
model/hitlog.py has the records and their two encodings."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from dentdemo.errors import ArgumentError
from dentdemo.model import hitlog
from dentdemo.model.hitlog import Body, Event, Hit, Record


class Surface(Protocol):
    """What the log reads of a DentableSurface."""

    @property
    def model(self) -> NDArray[np.float64]: ...
    @property
    def map_size(self) -> int: ...
    @property
    def max_dent_depth(self) -> float: ...


class PressLike(Protocol):
    """What the log reads of a checked press's contact."""

    @property
    def point(self) -> NDArray[np.float64]: ...
    @property
    def direction(self) -> NDArray[np.float64]: ...


class SurfaceRecorder:
    """A Carver's presses as records, for `Carver.log_to`: each call is one batch (and one
    frame: the calls are numbered from 0), each surface is declared by its first press with its
    name, map side and depth bound; poses are the surfaces' 4 x 4 models (12 numbers)."""

    def __init__(
        self, sink: Callable[[Record], None], surfaces: Mapping[str, Any], kind: type
    ) -> None:
        """`surfaces` maps names to instances of `kind` (api.py's DentableSurface)."""
        if not callable(sink):
            raise ArgumentError(f"sink must be callable, got {type(sink).__name__}")
        if not isinstance(surfaces, Mapping):
            raise ArgumentError(f"surfaces must map names to surfaces, got {surfaces!r}")
        self.sink = sink
        self._names: dict[int, str] = {}
        for name, surface in surfaces.items():
            if not isinstance(name, str) or not name:
                raise ArgumentError(f"surfaces: a name must be a non-empty string, got {name!r}")
            if not isinstance(surface, kind):
                raise ArgumentError(
                    f"surfaces['{name}'] must be a DentableSurface, got {type(surface).__name__}"
                )
            self._names[id(surface)] = name
        self._index: dict[int, int] = {}
        self._batch = 0

    def check(self, surfaces: Iterable[object]) -> None:
        for surface in surfaces:
            if id(surface) not in self._names:
                raise ArgumentError(
                    "a surface of this press has no name in the Carver's log_to(surfaces=...)"
                )

    def _declare(self, surface: Surface) -> int:
        key = id(surface)
        if key not in self._index:
            self._index[key] = len(self._index)
            spec = {
                "added": False,
                "map_size": surface.map_size,
                "max_dent_depth": surface.max_dent_depth,
            }
            self.sink(Body(self._batch, self._index[key], self._names[key], spec))
        return self._index[key]

    def presses(self, presses: Sequence[tuple[Surface, Surface, PressLike, float, float]]) -> None:
        for target, tool, _, _, _ in presses:
            self._declare(target)
            self._declare(tool)
        for target, tool, contact, depth, tool_depth in presses:
            self.sink(
                Hit(
                    self._batch,
                    self._batch,
                    self._index[id(target)],
                    self._index[id(tool)],
                    hitlog.matrix_pose(target.model),
                    hitlog.matrix_pose(tool.model),
                    _vec3(contact.point),
                    _vec3(contact.direction),
                    depth,
                    tool_depth,
                )
            )
        self._batch += 1

    def event(self, kind: str, surface: object = None) -> None:
        body = -1 if surface is None else self._index.get(id(surface), -1)
        if surface is not None and body < 0:
            return  # never pressed: nothing of it is in the log
        self.sink(Event(self._batch, kind, body))
        self._batch += 1


def _vec3(v: Iterable[float]) -> tuple[float, float, float]:
    x, y, z = (float(c) for c in v)
    return (x, y, z)
