"""Videos written frame by frame, for `render --video` and the window's recording (F6)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from dentdemo.app.gif import GifStream
from dentdemo.errors import DentdemoError
from dentdemo.extras import require_app
from dentdemo.outputs import temporary_beside


class VideoFile:
    """A video written frame by frame: MP4 (H.264 through imageio-ffmpeg's ffmpeg) or an animated
    GIF (Pillow) at `fps`, every frame `size` pixels. The file is written beside its final name
    and renamed by `finish`; `discard` removes it instead. `flag` names where the path came from
    in errors (--video, the window's recording)."""

    def __init__(self, size: tuple[int, int], out: Path, fps: float, flag: str = "--video"):
        self.size = size
        self.out = out
        self.fps = fps
        self.flag = flag
        self.frames = 0
        self._gif: GifStream | None = None
        self._writer = None
        try:
            out.parent.mkdir(parents=True, exist_ok=True)
            fd, self._tmp = temporary_beside(out, out.suffix)
        except OSError as exc:
            raise DentdemoError(f"{flag}: cannot create '{out}' ({exc.strerror})") from None
        if out.suffix.lower() == ".gif":
            handle = os.fdopen(fd, "wb")
            self._gif = GifStream(handle, size, round(100.0 / fps))
        else:
            os.close(fd)  # ffmpeg writes the file itself
            require_app(f"{flag}: an MP4", "imageio_ffmpeg")
            import imageio_ffmpeg

            self._writer = imageio_ffmpeg.write_frames(
                str(self._tmp),
                size,
                fps=fps,
                codec="libx264",
                quality=8,
                macro_block_size=1,
                output_params=["-pix_fmt", "yuv420p"],
                ffmpeg_log_level="error",
            )
            self._writer.send(None)

    def add(self, pixels: np.ndarray) -> None:
        """One frame: RGB8 rows top-down, `size` pixels."""
        if self._writer is not None:
            try:
                self._writer.send(np.ascontiguousarray(pixels).tobytes())
            except OSError as exc:  # ffmpeg went away: say so in one line
                detail = " ".join(str(exc).split())[:200]
                raise DentdemoError(f"{self.flag}: {self.out}: ffmpeg failed ({detail})") from None
        elif self._gif is not None:
            self._gif.add(pixels)  # written now: memory holds one frame
        self.frames += 1

    def finish(self) -> None:
        """Close the file and give it its name."""
        if self._writer is not None:
            self._writer.close()
        elif self._gif is not None:
            self._gif.close()
        os.chmod(self._tmp, 0o644)
        self._tmp.replace(self.out)

    def discard(self) -> None:
        if self._writer is not None:
            try:
                self._writer.close()
            except Exception:  # noqa: BLE001 - ffmpeg already gone; the file goes anyway
                pass
        elif self._gif is not None:
            self._gif.abort()
        self._tmp.unlink(missing_ok=True)
