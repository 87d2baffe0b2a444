"""How fast the simulation really runs: simulated seconds per wall-clock second over the last
frames. The window steps by wall time but at most a few physics steps a frame (Simulation.advance),
so when frames are slow the world falls behind real time; the panel says by how much."""

from __future__ import annotations

from collections import deque

#: Wall-clock seconds of frames the rate is taken over.
WINDOW_SECONDS = 1.0
#: A rate this far under the time scale set is "behind" (a frame's rounding to whole steps
#: stays inside it).
BEHIND = 0.05


class RealRate:
    """Frames' wall and simulated seconds, the last WINDOW_SECONDS of them."""

    def __init__(self) -> None:
        self._frames: deque[tuple[float, float]] = deque()
        self._wall = 0.0
        self._simulated = 0.0

    def add(self, wall_seconds: float, simulated_seconds: float) -> None:
        self._frames.append((wall_seconds, simulated_seconds))
        self._wall += wall_seconds
        self._simulated += simulated_seconds
        while len(self._frames) > 1 and self._wall - self._frames[0][0] >= WINDOW_SECONDS:
            wall, simulated = self._frames.popleft()
            self._wall -= wall
            self._simulated -= simulated

    def rate(self) -> float | None:
        """Simulated seconds per wall second; None before any wall time."""
        return self._simulated / self._wall if self._wall > 0.0 else None

    def text(self, scale: float, paused: bool) -> str:
        """The panel's line: the rate the world runs at, and when it falls behind the time
        scale set, that it does."""
        rate = self.rate()
        if paused:
            return "paused"
        if rate is None:
            return "rate: measuring"
        if rate < scale * (1.0 - BEHIND):
            return f"runs at {rate:.2f} x real time (behind the {scale:.2f} x set: slow frames)"
        return f"runs at {rate:.2f} x real time"
