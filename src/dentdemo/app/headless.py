"""`render`'s work: a scene run through the frame loop (app/loop.py) at its fixed dt on a headless
EGL context, frames written as PNGs; the window is the loop's other backend."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dentdemo import interrupt
from dentdemo.errors import DentdemoError
from dentdemo.gl.context import create_headless
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
from dentdemo.render.camera import OrbitCamera
from dentdemo.render.frame import RenderOptions


def render_headless(
    scene_file: Path,
    materials_files: list[Path],
    frames: int,
    out: Path,
    size: tuple[int, int],
    maps_dir: Path | None = None,
    denting: bool = True,
    options: RenderOptions | None = None,
    every_frame: bool = False,
    load_state: Path | None = None,
    save_state: Path | None = None,
    quality: str | None = None,
    eye: tuple[float, float, float] | None = None,
    target: tuple[float, float, float] | None = None,
    fov: float | None = None,
    video: Path | None = None,
    progress: bool = False,
    gltf: Path | None = None,
    hit_log: Path | None = None,
    compact_every: int | None = None,
) -> None:
    """Simulate `frames` steps and write the last frame (every frame, `out` % frame, with
    `every_frame`). `load_state` resumes a saved run first (the frames continue it);
    `save_state` saves the run after the last frame, before anything the carve budget deferred
    is flushed, so that a resumed run continues exactly. `eye`, `target` (world metres) and
    `fov` (degrees) replace the scene camera's, each where given. `video` (.mp4 or .gif) gets
    every frame as well, at the scene's frame rate. `gltf` (.glb or .gltf) gets every body as
    it is after the last frame. `hit_log` (.ddhl or .jsonl) gets every carve as a record
    (app/hitlog.py), written with the maps. `compact_every` (hits) makes `save_state` compact
    (app/compact.py)."""
    from dentdemo.app.controller import DemoController  # loads ODE
    from dentdemo.app.export import export_gltf, export_maps
    from dentdemo.app.loop import FrameLoop, ImageBackend, Tee, VideoBackend

    if frames < 1:
        raise DentdemoError(f"--frames: must be at least 1, got {frames}")
    materials = load_materials(materials_files)
    scene = load_scene(scene_file, materials)
    eye = eye if eye is not None else scene.camera.eye
    target = target if target is not None else scene.camera.target
    if max(abs(a - b) for a, b in zip(eye, target, strict=True)) < 1e-9:
        raise DentdemoError(f"--eye/--target: the camera cannot look at itself ({list(eye)})")
    gl = create_headless()
    try:
        app = DemoController(gl, scene, materials, size, denting=denting, quality=quality)
        app.view.options = options or RenderOptions()
        fov_deg = fov if fov is not None else scene.camera.fov_deg
        app.view.camera = OrbitCamera.from_eye(np.asarray(eye), np.asarray(target), fov_deg)
        if load_state is not None:
            from dentdemo.app.state import load_state as resume

            resume(app.sim, load_state)
        if compact_every is not None:
            from dentdemo.app.state import enable_compact_saves

            enable_compact_saves(app.sim, compact_every)
        recorder = None
        if hit_log is not None:
            from dentdemo.app.hitlog import HitRecorder

            recorder = HitRecorder()
            recorder.attach(app.sim)
        images = ImageBackend(size, out, every_frame)
        clip = VideoBackend(size, video, 1.0 / scene.physics.dt) if video is not None else None
        backend = images if clip is None else Tee(images, clip)
        try:
            FrameLoop(app, backend, fixed_dt=True).run(frames=frames, progress=progress)
            if clip is not None:
                interrupt.check()  # a Ctrl-C during the last frame: the video is not kept
        except BaseException:
            if clip is not None:
                clip.discard()
            raise
        if clip is not None:
            clip.finish()
        # Each later output is a safe point: a Ctrl-C stops before the next one (those written
        # stay whole); one during the last output stops nothing.
        if save_state is not None:
            from dentdemo.app.state import save_state as save

            interrupt.check()
            save(app.sim, save_state)
        app.sim.apply_queued()  # what the budget deferred, before the maps are exported
        if hit_log is not None and recorder is not None:
            from dentdemo.app.hitlog import write_log

            interrupt.check()
            write_log(hit_log, recorder.records)
        if maps_dir is not None:
            interrupt.check()
            export_maps(app.sim, maps_dir)
        if gltf is not None:
            interrupt.check()
            export_gltf(app.sim, gltf)
        app.close()
    finally:
        gl.release()
