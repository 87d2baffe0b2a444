"""The undo snapshot's cost per hit and its memory (not a test: numbers for docs/carve.md).

A 0.04 m ball pressed 1 mm into a 0.5 m plate (and 0.3 mm into itself) at 1024 texels/m, as the
sandbox's ball drop does, at random spots. Hits alternate with and without the undo log (so that
a busy machine slows both alike); for each: the CPU time of `press` (what the frame loop pays)
and of `press` then glFinish (the GPU's work too), and `UndoLog.record` alone. Medians.

    DENTDEMO_GL_BACKEND=egl PYTHONPATH=src python scripts/undo_cost.py [HITS]
"""

from __future__ import annotations

import statistics
import sys
import time

import numpy as np

import dentdemo
from dentdemo.carve.carver import Carver, CarverOptions
from dentdemo.carve.surface import map_size_for
from dentdemo.carve.undo import UndoLog
from dentdemo.gl.context import create_headless

HITS = int(sys.argv[1]) if len(sys.argv) > 1 else 100  # per arm
R, SIDE, TEXELS_PER_M = 0.04, 0.5, 1024.0


class TimedLog(UndoLog):
    """An UndoLog that keeps the CPU time of each `record`, ms."""

    times: list[float]

    def record(self, hits) -> None:  # noqa: ANN001
        start = time.perf_counter()
        super().record(hits)
        self.times.append((time.perf_counter() - start) * 1e3)


def main() -> None:
    gl = create_headless()
    plate_mesh = dentdemo.shape_mesh(dentdemo.Plate(SIDE))
    ball_mesh = dentdemo.shape_mesh(dentdemo.Sphere(R))
    plate = dentdemo.DentableSurface(gl.ctx, plate_mesh, map_size_for(plate_mesh, TEXELS_PER_M))
    ball = dentdemo.DentableSurface(gl.ctx, ball_mesh, map_size_for(ball_mesh, TEXELS_PER_M))
    carver = dentdemo.Carver(gl.ctx)
    inner = carver._live()
    log = TimedLog(inner.gl, depth=1 << 30, budget=1 << 40)  # nothing dropped: count all bytes
    log.times = []
    rng = np.random.default_rng(1)
    call: dict[bool, list[float]] = {True: [], False: []}
    with_gpu: dict[bool, list[float]] = {True: [], False: []}
    sizes: list[int] = []

    # The public carver's own, with the log and without (options are fixed at construction).
    inners = {
        on: Carver(inner.gl, CarverOptions(undo_log=log if on else None)) for on in (True, False)
    }

    def hit(with_log: bool, finish: bool) -> None:
        carver._carver = inners[with_log]
        x, z = rng.uniform(-0.2, 0.2, 2)
        ball.model = np.eye(4)
        ball.model[:3, 3] = (x, R, z)
        gl.ctx.finish()
        start = time.perf_counter()
        carver.press(plate, ball, dentdemo.Contact((x, 0, z), (0, -1, 0)), 1e-3, 3e-4)
        if finish:
            gl.ctx.finish()
        (with_gpu if finish else call)[with_log].append((time.perf_counter() - start) * 1e3)
        if with_log:
            sizes.append(sum(s.bytes for s in log.entries[-1]))

    for _ in range(4):  # warm-up: programs, index streams
        hit(True, False)
        hit(False, False)
    for arm in (call, with_gpu):
        arm[True].clear()
        arm[False].clear()
    log.times.clear()
    sizes.clear()
    for i in range(HITS):
        for with_log in (True, False) if i % 2 else (False, True):
            hit(with_log, False)
            hit(with_log, True)
        if len(log) >= 64:
            log.clear()
            carver.repair(plate)
            carver.repair(ball)
    med = statistics.median
    print(f"maps: plate {plate.map_size}², ball {ball.map_size}²; {HITS} hits per arm")
    for with_log in (False, True):
        print(
            f"undo log {'on ' if with_log else 'off'}: press() {med(call[with_log]):.3f} ms CPU, "
            f"press() + glFinish {med(with_gpu[with_log]):.3f} ms"
        )
    print(
        f"added per hit: {med(call[True]) - med(call[False]):.3f} ms CPU, "
        f"{med(with_gpu[True]) - med(with_gpu[False]):.3f} ms with the GPU's work; "
        f"UndoLog.record alone {med(log.times):.3f} ms"
    )
    kib = np.array(sizes) / 1024
    print(
        f"snapshot per hit (both bodies): median {np.median(kib):.1f} KiB, max {kib.max():.1f} "
        f"KiB; 64 MiB hold {int((64 << 10) / np.median(kib))} such hits (the depth, 64, binds)"
    )
    log.release()


if __name__ == "__main__":
    main()
