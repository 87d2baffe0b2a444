"""Saved state in the demo: F5 saves every body's maps and the physics to a folder, F9 loads it
back (app/state.py checks a state in full before applying it)."""

from __future__ import annotations

from pathlib import Path

from dentdemo.app import heap
from dentdemo.app.controllers import Keys
from dentdemo.app.simulation import Simulation
from dentdemo.app.status import Status

#: Where the demo's save-state key and button write, and load-state reads (a folder).
STATE_DIR = Path("dentdemo_state")


class StateController:
    """Save and load, with their outcome on the status line."""

    def __init__(self, sim: Simulation, status: Status) -> None:
        self.sim = sim
        self.status = status

    def keys(self) -> Keys:
        return {"f5": self.save, "f9": self.load}

    def save(self, directory: Path = STATE_DIR) -> bool:
        """Save every body's maps and the physics state (F5, panel "save state")."""
        from dentdemo.app.state import save_state

        return self.status.attempt(
            lambda: save_state(self.sim, directory, "save state (F5)"),
            lambda: f"saved to {directory}/ at t = {self.sim.world.time:.2f} s",
        )

    def load(self, directory: Path = STATE_DIR) -> bool:
        """Resume a saved state (F9, panel "load state"); a bad one changes nothing."""
        from dentdemo.app.state import load_state

        loaded = self.status.attempt(
            lambda: load_state(self.sim, directory),
            lambda: f"loaded {directory}/ at t = {self.sim.world.time:.2f} s",
        )
        if loaded:
            heap.settle()  # as after a reset (app/heap.py)
            self.status.say(self.status.line + "; undo history is not saved: none to undo")
        return loaded
