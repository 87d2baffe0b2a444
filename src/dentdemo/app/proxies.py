"""The collision proxies: per dynamic body that took a dent, its surface as the carve pressed it
(app/reshape.py's `DentProxy`), which becomes its ODE shape once deep enough; and, per carved
batch as deep as the undo log, how the proxies it pressed were before it, so that undo gives the
shapes back with the maps."""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from dentdemo.app.reshape import DentProxy, proxy_for, shape_field
from dentdemo.carve.undo import UNDO_DEPTH

if TYPE_CHECKING:
    from dentdemo.app.simulation import CarveRequest, SimBody
    from dentdemo.physics.world import PhysicsWorld


@dataclass(frozen=True)
class ProxyState:
    """A proxy as it was: each point's travel inwards (m), whether it was pressed, and the
    simulated time its ODE shape was last rebuilt (0: never)."""

    inward: NDArray[np.float64]
    shaped: NDArray[np.float64]
    rebuilt_at: float

    @staticmethod
    def of(proxy: DentProxy) -> ProxyState:
        return ProxyState(proxy.inward.copy(), proxy.shaped.copy(), proxy.rebuilt_at)


@dataclass
class ProxyBatch:
    """One carved batch's undo record: per body it pressed, its proxy before the batch, or None
    when the batch made the proxy."""

    before: dict[str, ProxyState | None] = field(default_factory=dict)


class CollisionProxies(dict[str, DentProxy]):
    """Body id -> its proxy, with the batches' undo records."""

    def __init__(self) -> None:
        super().__init__()
        #: Per carved batch, newest last, as deep as the undo log.
        self.history: deque[ProxyBatch] = deque(maxlen=UNDO_DEPTH)
        self._open = ProxyBatch()

    def note(self, body_id: str) -> None:
        """Keep how `body_id`'s proxy is before the batch being carved presses it."""
        if body_id not in self._open.before:
            proxy = self.get(body_id)
            self._open.before[body_id] = None if proxy is None else ProxyState.of(proxy)

    def press(
        self, request: CarveRequest, bodies: Mapping[str, SimBody], world: PhysicsWorld
    ) -> None:
        """Press the dynamic bodies' proxies as the carve pressed their maps, and give a body
        whose dents grew deep enough its dented surface as its shape (app/reshape.py)."""
        impact = request.impact
        sides = (
            (impact.body_a, request.model_a, impact.body_b, request.model_b, -impact.normal),
            (impact.body_b, request.model_b, impact.body_a, request.model_a, impact.normal),
        )
        for (body_id, model, tool_id, tool_model, direction), depth in zip(
            sides, (request.depth_a, request.depth_b), strict=True
        ):
            body, tool = bodies.get(body_id), bodies.get(tool_id)
            if depth <= 0.0 or body is None or tool is None or body.spec.static:
                continue
            shape = shape_field(tool.spec.shape, tool_model)
            if shape is None:
                continue
            proxy = self.get(body_id)
            if proxy is None:
                proxy = self[body_id] = proxy_for(body.spec.shape, body.mesh)
            proxy.press(model, shape, direction, depth, body.spec.material.max_dent_depth)
            if proxy.due():
                world.set_surface(body_id, *proxy.rebuilt())

    def close_batch(self, kept: bool) -> None:
        """The batch is carved: its record joins the history when the undo log kept the batch;
        a batch too large to keep empties the log, and nothing before it can be undone."""
        batch, self._open = self._open, ProxyBatch()
        if kept:
            self.history.append(batch)
        else:
            self.history.clear()

    def undo(self, bodies: Mapping[str, SimBody], world: PhysicsWorld) -> None:
        """The proxies, and the shapes made from them, as they were before the last batch."""
        batch = self.history.pop() if self.history else ProxyBatch()
        for body_id, saved in batch.before.items():
            if body_id not in bodies:
                continue
            if saved is None:  # no proxy before the batch: drop the one it made, and its shape
                made = self.pop(body_id, None)
                if made is not None and made.rebuilt_at > 0.0:
                    world.reset_shape(body_id)
                continue
            proxy = self[body_id]
            reshaped = proxy.rebuilt_at != saved.rebuilt_at
            proxy.inward, proxy.shaped, proxy.rebuilt_at = (
                saved.inward,
                saved.shaped,
                saved.rebuilt_at,
            )
            if reshaped:
                if proxy.rebuilt_at > 0.0:
                    world.set_surface(body_id, *proxy.surface())
                else:
                    world.reset_shape(body_id)

    def forget(self, body_id: str) -> bool:
        """Drop a repaired or removed body's proxy and its part of the history; whether it had
        one (its shape is then the pristine one again)."""
        for batch in self.history:
            batch.before.pop(body_id, None)
        return self.pop(body_id, None) is not None

    def clear(self) -> None:
        super().clear()
        self.history.clear()
        self._open = ProxyBatch()
