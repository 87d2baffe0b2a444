"""`render --video`: an MP4 that decodes, through the same library, to the frames asked for at
the size asked for, its last frame the same picture as the PNG; an animated GIF likewise; and a
progress bar on a terminal, silence elsewhere."""

from __future__ import annotations

import os
import pty
import select
import subprocess
import sys

import imageio_ffmpeg
import numpy as np
from PIL import Image

from cli_helpers import dentdemo


def test_mp4_decodes_to_the_frames_and_size_asked_for(tmp_path):
    out, video = tmp_path / "last.png", tmp_path / "clip.mp4"
    result = dentdemo(
        "render", "--frames", "24", "--size", "192x108", "--out", out, "--video", video
    )
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""  # no terminal: no progress bar
    reader = imageio_ffmpeg.read_frames(str(video))
    meta = next(reader)
    frames = [np.frombuffer(f, np.uint8).reshape(108, 192, 3) for f in reader]
    assert tuple(meta["size"]) == (192, 108) and meta["fps"] == 60.0
    assert len(frames) == 24
    last = np.asarray(Image.open(out)).astype(int)
    assert np.abs(frames[-1].astype(int) - last).mean() < 4.0  # H.264 is lossy, slightly
    assert np.abs(frames[0].astype(int) - last).mean() > np.abs(frames[-1] - last).mean()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_gif_has_every_frame(tmp_path):
    video = tmp_path / "clip.gif"
    result = dentdemo(
        "render", "--frames", "7", "--size", "96x54", "--out", tmp_path / "x.png", "--video", video
    )
    assert result.returncode == 0, result.stderr
    with Image.open(video) as gif:
        assert gif.n_frames == 7 and gif.size == (96, 54)


def test_progress_bar_on_a_terminal(tmp_path):
    main, follower = pty.openpty()
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "dentdemo",
            "render",
            "--frames",
            "20",
            "--size",
            "64x36",
            "--out",
            str(tmp_path / "x.png"),
        ],
        stdout=subprocess.PIPE,
        stderr=follower,
    )
    os.close(follower)
    seen = b""
    while True:
        ready, _, _ = select.select([main], [], [], 60)
        if not ready:
            break
        try:
            chunk = os.read(main, 4096)
        except OSError:  # the terminal closed with the process
            break
        if not chunk:
            break
        seen += chunk
    os.close(main)
    assert proc.wait(timeout=60) == 0
    assert b"frames" in seen and b"/20 [" in seen  # "k/20 [elapsed<left, rate]"
