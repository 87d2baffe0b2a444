"""Timing helpers: medians after warm-up, GPU timer queries where the driver has them."""

from __future__ import annotations

import contextlib
import statistics
import time
from collections.abc import Callable, Iterator, Sequence

import moderngl

from dentdemo import interrupt


def median_ms(
    run: Callable[[], object], finish: Callable[[], None], reps: int, warmup: int = 2
) -> tuple[float, list[float]]:
    """Median wall milliseconds of `run` (each ended by `finish`, e.g. ctx.finish)."""
    for _ in range(warmup):
        interrupt.check()
        run()
        finish()
    times = []
    for _ in range(reps):
        interrupt.check()
        finish()
        start = time.perf_counter()
        run()
        finish()
        times.append((time.perf_counter() - start) * 1e3)
    return statistics.median(times), times


def interleaved_medians(
    runs: Sequence[Callable[[], object]], finish: Callable[[], None], reps: int, warmup: int = 2
) -> list[float]:
    """Median wall milliseconds of each of `runs`, measured in turn within every repetition so
    that a machine's drift (other load, clocks) falls on all of them alike."""
    for _ in range(warmup):
        for run in runs:
            interrupt.check()
            run()
            finish()
    times: list[list[float]] = [[] for _ in runs]
    for _ in range(reps):
        for run, out in zip(runs, times, strict=True):
            interrupt.check()
            finish()
            start = time.perf_counter()
            run()
            finish()
            out.append((time.perf_counter() - start) * 1e3)
    return [statistics.median(t) for t in times]


class PassTimer:
    """Per-pass GPU time with GL_TIME_ELAPSED queries, else wall time around finish()."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self.gpu = "GL_ARB_timer_query" in ctx.extensions or ctx.version_code >= 330
        self.totals: dict[str, list[float]] = {}
        self._current: dict[str, float] = {}

    @contextlib.contextmanager
    def __call__(self, name: str) -> Iterator[None]:
        if self.gpu:
            query = self.ctx.query(time=True)
            with query:
                yield
            ms = query.elapsed / 1e6  # reading the result waits for the GPU (benchmark only)
            del query
        else:
            self.ctx.finish()
            start = time.perf_counter()
            yield
            self.ctx.finish()
            ms = (time.perf_counter() - start) * 1e3
        self._current[name] = self._current.get(name, 0.0) + ms

    def end_hit(self) -> None:
        for name, ms in self._current.items():
            self.totals.setdefault(name, []).append(ms)
        self._current = {}

    def medians(self) -> dict[str, float]:
        return {name: statistics.median(values) for name, values in self.totals.items()}
