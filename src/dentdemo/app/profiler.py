"""The profiler strip: the last seconds of frame phases, in milliseconds of wall time as the
frame loop measures them (physics, carve, render, present). Without `measure` the GPU runs the
carve and the render asynchronously: their GPU time then shows in the phase that waits for it
(present, whose buffer swap or image read waits for the frame)."""

from __future__ import annotations

from collections import deque

import numpy as np
from numpy.typing import NDArray

#: The phases of a frame, in the order the loop runs them.
PHASES = ("physics", "carve", "render", "present")
#: Seconds of history the strip keeps.
HISTORY_SECONDS = 5.0


class Profiler:
    """Frame samples of the last `seconds` (by the time each was taken)."""

    def __init__(self, seconds: float = HISTORY_SECONDS) -> None:
        self.seconds = seconds
        self._samples: deque[tuple[float, tuple[float, ...]]] = deque()

    def add(self, at: float, milliseconds: tuple[float, float, float, float]) -> None:
        """One frame taken at `at` (seconds, monotonic): ms per phase, in PHASES order."""
        self._samples.append((at, tuple(float(m) for m in milliseconds)))
        while self._samples and self._samples[0][0] < at - self.seconds:
            self._samples.popleft()

    def __len__(self) -> int:
        return len(self._samples)

    def series(self, phase: str) -> NDArray[np.float32]:
        """One phase's milliseconds, oldest first (float32, as imgui plots take them)."""
        index = PHASES.index(phase)
        return np.array([ms[index] for _, ms in self._samples], dtype=np.float32)

    def mean(self, phase: str) -> float:
        values = self.series(phase)
        return float(values.mean()) if len(values) else 0.0
