"""Video recording in the demo: F6 starts recording the window (without the panels) to an MP4 at
the scene's frame rate, the simulation stepping one fixed dt per frame meanwhile, so the video
plays in real time; F6 again finishes it."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dentdemo.app.controllers import Keys
from dentdemo.app.controllers.view import ViewController
from dentdemo.app.simulation import Simulation
from dentdemo.app.status import Status
from dentdemo.app.video import VideoFile
from dentdemo.errors import DentdemoError


class RecordingController:
    """The video being recorded, if any."""

    def __init__(self, sim: Simulation, view: ViewController, status: Status) -> None:
        self.sim = sim
        self.view = view
        self.status = status
        #: The video being recorded from the window (F6), or None.
        self.recorder: VideoFile | None = None

    def keys(self) -> Keys:
        return {"f6": self.toggle}

    def toggle(self, path: Path | None = None) -> bool:
        """Start recording the view's frames to `path` (or the next free dentdemo_NNN.mp4), or
        stop and finish the recording. Returns whether it records now; the outcome becomes the
        status line."""
        if self.recorder is not None:
            self.stop()
            return False
        target = path or _next_free("dentdemo_{:03d}.mp4")
        fps = 1.0 / self.sim.scene.physics.dt
        try:
            self.recorder = VideoFile(self.view.renderer.size, target, fps, "recording")
        except DentdemoError as exc:
            self.status.error(exc)
            return False
        self.status.say(f"recording {target} at {fps:g} fps (F6 stops)")
        return True

    def record_frame(self, pixels: np.ndarray) -> None:
        """One frame of the recording (RGB8 rows top-down, the renderer's size); a failing
        writer ends the recording with its one line."""
        if self.recorder is None:
            return
        try:
            self.recorder.add(pixels)
        except DentdemoError as exc:
            recorder, self.recorder = self.recorder, None
            recorder.discard()
            self.status.error(exc)

    def stop(self) -> None:
        """Finish the recording, if one runs (also when the window is resized: a video keeps
        one size)."""
        recorder, self.recorder = self.recorder, None
        if recorder is None:
            return
        try:
            recorder.finish()
        except DentdemoError as exc:  # no frames, or a full disk: nothing replaced
            self.status.error(exc)
            return
        seconds = recorder.frames / recorder.fps
        self.status.say(f"wrote {recorder.out} ({recorder.frames} frames, {seconds:.2f} s)")


def _next_free(pattern: str) -> Path:
    """The first of pattern.format(1), pattern.format(2), ... that does not exist yet."""
    index = 1
    while Path(pattern.format(index)).exists():
        index += 1
    return Path(pattern.format(index))
