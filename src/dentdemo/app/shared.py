"""Values made once per key and shared by every holder: the meshes of bodies of one shape (the
simulation's mesh and its GPU buffers, the scenery's coarser render meshes). A ball dropped
beside balls of its radius then makes no mesh, buffer or vertex array of its own."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Any, Generic, TypeVar

K = TypeVar("K", bound=Hashable)
V = TypeVar("V")


class Shared(Generic[K, V]):
    """`take(key, *args)` gives the value for `key`, made the first time; `give_back(key)`
    once per take, and the last holder's give-back releases it (`release`)."""

    def __init__(self, make: Callable[..., V], release: Callable[[V], None]) -> None:
        self._make, self._release = make, release
        self._held: dict[K, list] = {}  # key -> [value, holders]

    def take(self, key: K, *args: Any) -> V:
        """The value for `key`, made by `make(key, *args)` if no one holds it."""
        held = self._held.get(key)
        if held is None:
            held = self._held[key] = [self._make(key, *args), 0]
        held[1] += 1
        return held[0]

    def give_back(self, key: K) -> None:
        """One holder of `key`'s value is done with it: released with the last (a key no one
        holds, whose value went already, is left alone)."""
        held = self._held.get(key)
        if held is None:
            return
        held[1] -= 1
        if held[1] <= 0:
            del self._held[key]
            self._release(held[0])

    def release(self) -> None:
        """Every value released, whoever still holds it (the owner is closing)."""
        for value, _ in self._held.values():
            self._release(value)
        self._held.clear()
