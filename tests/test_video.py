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
import pytest
from PIL import Image

from cli_helpers import dentdemo


@pytest.mark.slow
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


@pytest.mark.slow
def test_gif_has_every_frame(tmp_path):
    """Streamed frame by frame: every frame, 1/60 s each as GIF rounds it (2 cs), looping, the
    last one the PNG's picture in 256 colours, and no temporary file left."""
    video, out = tmp_path / "clip.gif", tmp_path / "x.png"
    result = dentdemo("render", "--frames", "7", "--size", "96x54", "--out", out, "--video", video)
    assert result.returncode == 0, result.stderr
    last = np.asarray(Image.open(out).convert("RGB")).astype(int)
    with Image.open(video) as gif:
        assert gif.n_frames == 7 and gif.size == (96, 54)
        assert gif.info.get("loop") == 0
        frames = []
        for k in range(gif.n_frames):
            gif.seek(k)
            assert gif.info["duration"] == 20
            frames.append(np.asarray(gif.convert("RGB")).astype(int))
    assert np.abs(frames[-1] - last).mean() < 3.0  # an adaptive palette of 256 colours
    assert np.abs(frames[0] - last).mean() > np.abs(frames[-1] - last).mean()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_a_gif_frame_stream_reads_back_exactly(tmp_path):
    """GifStream against Pillow's reader: frames of up to 256 colours come back exactly, each
    with its own palette (no shared table), whatever the count."""
    from dentdemo.app.gif import GifStream

    rng = np.random.default_rng(7)
    frames = []
    for k in range(5):
        colours = rng.integers(0, 256, (200 + k, 3))
        frames.append(colours[rng.integers(0, len(colours), (30, 41))].astype(np.uint8))
    path = tmp_path / "s.gif"
    with open(path, "wb") as handle:
        stream = GifStream(handle, (41, 30), 5)
        for frame in frames:
            stream.add(frame)
        stream.close()
    with Image.open(path) as gif:
        assert gif.n_frames == 5
        for k, frame in enumerate(frames):
            gif.seek(k)
            assert gif.info["duration"] == 50
            assert np.array_equal(np.asarray(gif.convert("RGB")), frame)


@pytest.mark.slow
def test_temporary_names_are_unique_and_fit_beside_a_long_name(tmp_path):
    import os

    from dentdemo.outputs import NAME_MAX, temporary_beside

    long = tmp_path / ("n" * 250 + ".png")  # a legal name: 254 bytes
    made = [temporary_beside(long, ".png") for _ in range(2)]
    for fd, path in made:
        os.close(fd)
        assert len(path.name.encode()) <= NAME_MAX and path.parent == tmp_path
    assert made[0][1] != made[1][1]
    result = dentdemo("render", "--frames", "2", "--size", "32x18", "--out", long)
    assert result.returncode == 0, result.stderr
    assert long.exists()


@pytest.mark.slow
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
