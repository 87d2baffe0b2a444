"""Videos written frame by frame, for `render --video` and the window's recording (F6)."""

from __future__ import annotations

import os
import struct
import subprocess
import tempfile
from fractions import Fraction
from pathlib import Path

import numpy as np

from dentdemo.app.gif import GifStream
from dentdemo.errors import DentdemoError
from dentdemo.extras import require_app
from dentdemo.outputs import hold, remove_leftovers, temporary_beside

#: H.264's constant rate factor (0 lossless .. 51 worst): imageio-ffmpeg's quality 8 of 10.
CRF = 10
#: What of ffmpeg's stderr a refusal quotes, characters.
DETAIL = 200


def _detail(text: str) -> str:
    """The last line of ffmpeg's messages, on one line."""
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return (lines[-1] if lines else "no message")[:DETAIL]


def mp4_complete(path: Path) -> bool:
    """True when `path` is a whole MP4: its top-level boxes (32-bit size, type; size 1: a 64-bit
    size follows) tile the file exactly and include the movie header `moov`, which ffmpeg
    writes last (a full disk cuts the file before it)."""
    try:
        with open(path, "rb") as handle:
            size = os.fstat(handle.fileno()).st_size
            at, boxes = 0, set()
            while at + 8 <= size:
                handle.seek(at)
                length, kind = struct.unpack(">I4s", handle.read(8))
                if length == 1:
                    (length,) = struct.unpack(">Q", handle.read(8))
                if length < 8:
                    return False
                boxes.add(kind)
                at += length
    except OSError:
        return False
    return at == size and b"moov" in boxes


class VideoFile:
    """A video written frame by frame: MP4 (H.264 through imageio-ffmpeg's ffmpeg) or an animated
    GIF (Pillow) at `fps`, every frame `size` pixels. The file is written beside its final name
    (leftovers of killed writers of that name are removed first, with one line) and renamed by
    `finish` once it is checked whole; a failed write (a full disk) or one without frames
    removes it and raises one line, the previous file of that name kept. `discard` removes it.
    `flag` names where the path came from in errors (--video, the window's recording)."""

    def __init__(self, size: tuple[int, int], out: Path, fps: float, flag: str = "--video"):
        self.size = size
        self.out = out
        self.fps = fps
        self.flag = flag
        self.frames = 0
        self._gif: GifStream | None = None
        self._ffmpeg: subprocess.Popen[bytes] | None = None
        try:
            out.parent.mkdir(parents=True, exist_ok=True)
            remove_leftovers(flag, out, out.suffix)
            fd, self._tmp = temporary_beside(out, out.suffix)
            self._lock = hold(self._tmp)  # other writers' clean-up leaves it alone
        except OSError as exc:
            raise DentdemoError(f"{flag}: cannot create '{out}' ({exc.strerror})") from None
        if out.suffix.lower() == ".gif":
            handle = os.fdopen(fd, "wb")
            try:
                self._gif = GifStream(handle, size, round(100.0 / fps))
            except OSError as exc:
                self._fail(exc.strerror or str(exc))
        else:
            os.close(fd)  # ffmpeg writes the file itself
            self._start_ffmpeg()

    def _start_ffmpeg(self) -> None:
        require_app(f"{self.flag}: an MP4", "imageio_ffmpeg")
        import imageio_ffmpeg

        rate = str(Fraction(self.fps).limit_denominator())
        width, height = self.size
        command = [
            imageio_ffmpeg.get_ffmpeg_exe(),
            *("-y", "-v", "error", "-f", "rawvideo", "-vcodec", "rawvideo"),
            *("-s", f"{width}x{height}", "-pix_fmt", "rgb24", "-r", rate, "-i", "-", "-an"),
            *("-vcodec", "libx264", "-pix_fmt", "yuv420p", "-crf", str(CRF), "-f", "mp4"),
            str(self._tmp),
        ]
        # ffmpeg's messages go to a file, quoted in one line when it fails (a pipe could fill
        # and stall it); its own session keeps a terminal's Ctrl-C ours to handle.
        self._log = tempfile.TemporaryFile()
        self._ffmpeg = subprocess.Popen(
            command,
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=self._log,
            start_new_session=True,
        )

    def _ffmpeg_says(self) -> str:
        self._log.seek(0)
        return _detail(self._log.read().decode(errors="replace"))

    def _fail(self, why: str) -> None:
        """Remove the temporary file and raise the one line: the previous file is kept."""
        self.discard()
        raise DentdemoError(f"{self.flag}: '{self.out}' not written ({why}); nothing replaced")

    def add(self, pixels: np.ndarray) -> None:
        """One frame: RGB8 rows top-down, `size` pixels."""
        try:
            if self._ffmpeg is not None:
                assert self._ffmpeg.stdin is not None
                self._ffmpeg.stdin.write(np.ascontiguousarray(pixels).tobytes())
            elif self._gif is not None:
                self._gif.add(pixels)  # written now: memory holds one frame
        except OSError as exc:  # a full disk, or ffmpeg went away (it says why)
            why = exc.strerror or str(exc)
            if self._ffmpeg is not None:
                self._ffmpeg.kill()
                self._ffmpeg.wait()
                why = f"ffmpeg: {self._ffmpeg_says()}"
            self._fail(why)
        self.frames += 1

    def finish(self) -> None:
        """Close the file, check it whole and give it its name."""
        if self.frames == 0:
            self._fail("no frames were recorded")
        try:
            if self._ffmpeg is not None:
                assert self._ffmpeg.stdin is not None
                self._ffmpeg.stdin.close()
                code = self._ffmpeg.wait()
                if code != 0 or not mp4_complete(self._tmp):
                    self._fail(f"ffmpeg: {self._ffmpeg_says()}")
            elif self._gif is not None:
                self._gif.close()
                self._gif = None
            os.chmod(self._tmp, 0o644)
            self._tmp.replace(self.out)
        except OSError as exc:
            self._fail(exc.strerror or str(exc))
        self._release()

    def _release(self) -> None:
        if self._lock >= 0:
            os.close(self._lock)
            self._lock = -1
        if self._ffmpeg is not None:
            self._log.close()

    def discard(self) -> None:
        if self._ffmpeg is not None and self._ffmpeg.poll() is None:
            self._ffmpeg.kill()
            self._ffmpeg.wait()
        if self._ffmpeg is not None and self._ffmpeg.stdin is not None:
            try:
                self._ffmpeg.stdin.close()
            except OSError:  # ffmpeg already gone: nothing to flush
                pass
        if self._gif is not None:
            try:
                self._gif.abort()
            except OSError:  # the disk is full: the file goes anyway
                pass
            self._gif = None
        self._tmp.unlink(missing_ok=True)
        self._release()
