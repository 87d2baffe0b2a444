"""What the Simulation counts: per frame (hits, impacts, the phases' milliseconds) and per body
(its dents), as records the panel, the bench and saved states read."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class DentStats:
    """The dents carved into one body since it was made (or the last reset)."""

    count: int = 0
    #: The deepest single press, metres (overlapping dents are not summed: the map keeps the
    #: deepest surface, and is never read back to find it).
    deepest: float = 0.0

    def add(self, depth: float) -> None:
        """One more dent, `depth` metres deep."""
        self.count += 1
        self.deepest = max(self.deepest, depth)


@dataclass
class SimStats:
    frames: int = 0
    hits: int = 0
    impacts: int = 0
    physics_ms: float = 0.0
    carve_ms: float = 0.0  # CPU time issuing the last frame's carves (the GPU runs them async)
    carve_ms_per_hit: float = 0.0
