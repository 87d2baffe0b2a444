"""Undo and repair in the demo: Ctrl+Z takes back the last frame's hits (Simulation.undo), and
the panel's "repair" gives the body dented deeper by the last hit its pristine maps back."""

from __future__ import annotations

from dentdemo.app.controllers import Keys
from dentdemo.app.simulation import Simulation
from dentdemo.app.status import Status


class UndoController:
    """Undo and repair, with their outcome on the status line."""

    def __init__(self, sim: Simulation, status: Status) -> None:
        self.sim = sim
        self.status = status

    def keys(self) -> Keys:
        return {"ctrl+z": self.undo}

    def undo(self) -> bool:
        """Ctrl+Z, panel "undo": take back the last frame's hits (Simulation.undo)."""
        done = self.sim.undo()
        left = len(self.sim.undo_log)
        self.status.say(f"undid the last hits ({left} more to undo)" if done else "nothing to undo")
        return done

    def repair_target(self) -> str | None:
        """The body the panel's "repair" button repairs: the one dented deeper by the last hit;
        None before any hit or once it is gone."""
        hit = self.sim.last_hit
        body = None if hit is None else hit.deepest()[0]
        return body if body in self.sim.bodies else None

    def repair(self, body_id: str) -> bool:
        """Panel "repair": the body's pristine maps back (Simulation.repair)."""
        if body_id not in self.sim.bodies:
            self.status.say(f"repair: no body {body_id!r}")
            return False
        self.sim.repair(body_id)
        self.status.say(f"repaired {body_id}")
        return True
