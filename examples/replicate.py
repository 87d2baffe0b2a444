"""Two processes, one set of dents: the sender simulates a scene and streams each carve as a
hit-log record through a pipe as it happens; the receiver runs no physics, only carves what it
is sent onto its own copy of the scene's bodies, and renders them. Both write their maps at
the end, and the sender compares them byte for byte. Run:

    python examples/replicate.py --frames 240 --out-dir replicate/

It prints the hits, the bytes sent and the rate (bytes per simulated second), and exits 0 when
the receiver's maps equal the sender's.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

from dentdemo.app.controller import DemoController
from dentdemo.app.export import export_maps
from dentdemo.app.hitlog import HitRecorder, Replayer
from dentdemo.gl.context import GLContext, create_headless
from dentdemo.model import hitlog
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
from dentdemo.resources import assets_dir

SIZE = (640, 360)


def _app(scene_file: Path) -> tuple[GLContext, DemoController]:
    gl = create_headless()
    materials = load_materials()
    return gl, DemoController(gl, load_scene(scene_file, materials), materials, SIZE)


def send(scene_file: Path, frames: int, out_dir: Path) -> int:
    receiver = subprocess.Popen(
        [
            sys.executable,
            __file__,
            "--receive",
            "--scene",
            str(scene_file),
            "--out-dir",
            str(out_dir),
        ],
        stdin=subprocess.PIPE,
    )
    assert receiver.stdin is not None
    pipe = receiver.stdin
    encoder = hitlog.Encoder()
    sent = [0, 0]  # bytes, records

    def write(data: bytes) -> None:
        pipe.write(data)
        sent[0] += len(data)

    def sink(record: hitlog.Record) -> None:
        write(encoder.encode(record))
        sent[1] += 1

    gl, app = _app(scene_file)
    recorder = HitRecorder(sink=sink, keep=False)
    recorder.attach(app.sim)
    write(hitlog.header())
    start = time.perf_counter()
    for _ in range(frames):
        app.sim.step()
        pipe.flush()  # this frame's records leave now, not when a buffer fills
    app.sim.apply_queued()
    write(hitlog.end(sent[1]))
    pipe.close()
    elapsed = time.perf_counter() - start
    mine = out_dir / "sender"
    export_maps(app.sim, mine)
    app.screenshot(out_dir / "sender.png")
    app.close()
    gl.release()
    if receiver.wait() != 0:
        print("replicate: the receiver failed", file=sys.stderr)
        return 1
    theirs = out_dir / "receiver"
    names = sorted(p.name for p in mine.iterdir())
    differ = [n for n in names if (mine / n).read_bytes() != (theirs / n).read_bytes()]
    seconds = frames * app.sim.scene.physics.dt
    print(
        f"{recorder.hits} hits in {frames} frames ({seconds:.1f} simulated s, {elapsed:.1f} s"
        f" here): {sent[0]} bytes sent, {sent[0] / seconds:.0f} bytes per simulated second,"
        f" {sent[0] / max(recorder.hits, 1):.0f} a hit"
    )
    if differ or sorted(p.name for p in theirs.iterdir()) != names:
        print(f"replicate: the maps differ: {differ}", file=sys.stderr)
        return 1
    print(f"the receiver's {len(names)} map files equal the sender's, byte for byte")
    return 0


def receive(scene_file: Path, out_dir: Path) -> int:
    gl, app = _app(scene_file)
    decoder = hitlog.Decoder("pipe")
    checker = hitlog.Checker()
    replayer = Replayer(app.sim)
    stream = sys.stdin.buffer.fileno()
    while chunk := os.read(stream, 1 << 16):
        for at, record in decoder.feed(chunk):
            replayer.apply(checker.add(record, at), at)
    if not decoder.ended:
        print("replicate: the stream ended before its end record", file=sys.stderr)
        return 1
    replayer.finish()
    export_maps(app.sim, out_dir / "receiver")
    app.screenshot(out_dir / "receiver.png")
    app.close()
    gl.release()
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", type=Path, default=assets_dir() / "scenes" / "ball_drop.toml")
    parser.add_argument("--frames", type=int, default=240)
    parser.add_argument("--out-dir", type=Path, default=Path("replicate"))
    parser.add_argument("--receive", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    args.out_dir.mkdir(parents=True, exist_ok=True)
    if args.receive:
        return receive(args.scene, args.out_dir)
    return send(args.scene, args.frames, args.out_dir)


if __name__ == "__main__":
    sys.exit(main())
