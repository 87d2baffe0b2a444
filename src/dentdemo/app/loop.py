"""The one frame loop. A frame steps the simulation (one fixed dt, or the wall time owed, scaled
by the time scale), describes what it shows, renders that and hands the image to a backend: the
window (app/window.py) or images on disk (`ImageBackend`). `render`, `demo` (with or without a
window), `--exit-after`, the bench and the tests all run frames through here."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import moderngl

from dentdemo import interrupt
from dentdemo.app import heap
from dentdemo.app.controller import DemoController
from dentdemo.app.video import VideoFile
from dentdemo.outputs import write_png
from dentdemo.progress import progress_bar


class Backend(Protocol):
    """Where frames go."""

    def open(self) -> bool:
        """Handle input; False once the user closed it (a window) or never (images)."""
        ...

    def size(self) -> tuple[int, int]:
        """Pixels the next frame should have."""
        ...

    def target(self) -> moderngl.Framebuffer | None:
        """Where the renderer draws the finished frame (a window's screen), or None for the
        renderer's own output framebuffer."""
        ...

    def present(self, app: DemoController, output: moderngl.Framebuffer, last: bool) -> None:
        """Show or keep the rendered frame (`last`: the loop ends after it)."""
        ...


@dataclass(frozen=True)
class FrameTiming:
    """Milliseconds of one frame by phase (with `measure`, each phase ends with glFinish)."""

    physics_ms: float
    carve_ms: float
    render_ms: float
    total_ms: float
    #: The backend's share: the window's panel and buffer swap, or writing the image.
    present_ms: float = 0.0


class FrameLoop:
    """Frames of `app` into `backend`. `fixed_dt`: one physics step of the scene's dt per frame
    (deterministic: headless renders, --exit-after, the bench); else the wall time since the last
    frame, scaled by the time scale (the interactive window)."""

    def __init__(self, app: DemoController, backend: Backend, fixed_dt: bool) -> None:
        self.app = app
        self.backend = backend
        self.fixed_dt = fixed_dt
        self.frames = 0
        heap.settle()  # the scene is loaded: its objects out of the collector's way (app/heap.py)
        self._last = time.perf_counter()

    def frame(self, last: bool = False, measure: bool = False) -> FrameTiming:
        """Step, render and present one frame."""
        interrupt.check()
        self.app.reload.poll()  # the demo's watched materials and scene files; else nothing
        finish = self.app.gl.ctx.finish if measure else _nothing
        start = time.perf_counter()
        wall, self._last = start - self._last, start
        if self.fixed_dt or self.app.recording.recorder is not None:  # a recording: fixed step
            if not self.app.paused:
                self.app.sim.step()
            # One dt a frame however long the frame took: slow frames run behind real time.
            self.app.rate.add(wall, 0.0 if self.app.paused else self.app.sim.scene.physics.dt)
        else:
            self.app.update(wall)
        stepped = time.perf_counter()
        finish()  # the frame's carves done on the GPU
        carved = time.perf_counter()
        self.app.resize(self.backend.size())
        output = self.app.view.render(self.backend.target())
        finish()
        rendered = time.perf_counter()
        self.backend.present(self.app, output, last)
        presented = time.perf_counter()
        self.frames += 1
        stats = self.app.sim.stats
        timing = FrameTiming(
            physics_ms=stats.physics_ms,
            carve_ms=(carved - stepped) * 1e3 + stats.carve_ms,
            render_ms=(rendered - carved) * 1e3,
            total_ms=(rendered - start) * 1e3,
            present_ms=(presented - rendered) * 1e3,
        )
        self.app.tools.profiler.add(
            presented, (timing.physics_ms, timing.carve_ms, timing.render_ms, timing.present_ms)
        )
        return timing

    def run(
        self, frames: int | None = None, until_time: float | None = None, progress: bool = False
    ) -> int:
        """Frames until the backend closes, `frames` frames were made, or the simulation reached
        `until_time` seconds (the frame that reaches it is the last). Returns how many. With
        `progress` and a terminal on stderr, a progress bar counts the frames."""
        bar = progress_bar(frames, "frames") if progress else None
        made = 0
        while self.backend.open():
            if frames is not None and made >= frames:
                break
            time_left = until_time is not None and (
                self.app.sim.world.time + self.app.sim.scene.physics.dt >= until_time - 1e-9
            )
            last = (frames is not None and made == frames - 1) or bool(time_left)
            self.frame(last=last)
            made += 1
            if bar is not None:
                bar.update(1)
            if last:
                break
        if bar is not None:
            bar.close()
        return made


def _nothing() -> None:
    return None


class OffscreenBackend:
    """A backend without a window: always open, frames in the renderer's own output."""

    _size: tuple[int, int]

    def open(self) -> bool:
        return True

    def size(self) -> tuple[int, int]:
        return self._size

    def target(self) -> None:
        return None


class VideoBackend(OffscreenBackend):
    """Every frame into one `VideoFile` at the simulation's frame rate (render --video)."""

    def __init__(self, size: tuple[int, int], out: Path, fps: float) -> None:
        self._size = size
        self.out = out
        self.fps = fps
        self.video = VideoFile(size, out, fps)

    def present(self, app: DemoController, output: moderngl.Framebuffer, last: bool) -> None:
        self.video.add(app.view.renderer.read_rgb())

    def finish(self) -> None:
        self.video.finish()

    def discard(self) -> None:
        self.video.discard()


class ImageBackend(OffscreenBackend):
    """Frames as PNG files: every frame (`out` holds a %d pattern) or only the last one; none
    when `out` is None (the bench)."""

    def __init__(self, size: tuple[int, int], out: Path | None, every_frame: bool = False) -> None:
        self._size = size
        self.out = out
        self.every_frame = every_frame
        self._index = 0

    def present(self, app: DemoController, output: moderngl.Framebuffer, last: bool) -> None:
        index, self._index = self._index, self._index + 1
        if self.out is None or not (self.every_frame or last):
            return
        target = self.out.with_name(self.out.name % index) if self.every_frame else self.out
        write_png(target, app.view.renderer.read_rgb())


class Tee(OffscreenBackend):
    """Every frame to several offscreen backends at once (images and a video)."""

    def __init__(self, *backends: Backend) -> None:
        self.backends = backends
        self._size = backends[0].size()

    def present(self, app: DemoController, output: moderngl.Framebuffer, last: bool) -> None:
        for backend in self.backends:
            backend.present(app, output, last)
