"""A scene simulated at its fixed dt and drawn on EGL: the same Simulation and Renderer as the
window, with no window."""

from __future__ import annotations

from pathlib import Path

from dentdemo.errors import DentdemoError
from dentdemo.gl.context import create_headless
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
from dentdemo.outputs import write_png
from dentdemo.render.camera import OrbitCamera
from dentdemo.render.renderer import Renderer, RenderOptions


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
) -> None:
    """Simulate `frames` steps and write the last frame (every frame, `out` % frame, with
    `every_frame`). `load_state` resumes a saved run first (the frames continue it);
    `save_state` saves the run after the last frame, before anything the carve budget deferred
    is flushed, so that a resumed run continues exactly."""
    from dentdemo.app.simulation import Simulation  # loads ODE

    if frames < 1:
        raise DentdemoError(f"--frames: must be at least 1, got {frames}")
    materials = load_materials(materials_files)
    scene = load_scene(scene_file, materials)
    every = every_frame
    gl = create_headless()
    try:
        sim = Simulation(gl, scene, materials, denting=denting)
        renderer = Renderer(gl, size)
        camera = OrbitCamera.from_eye(scene.camera.eye, scene.camera.target, scene.camera.fov_deg)
        opts = options or RenderOptions()
        if load_state is not None:
            from dentdemo.app.state import load_state as resume

            resume(sim, load_state)
        for frame in range(frames):
            sim.step()
            if every or frame == frames - 1:
                renderer.render(sim, camera, opts)
                target = out.with_name(out.name % frame) if every else out
                write_png(target, renderer.read_rgb())
        if save_state is not None:
            from dentdemo.app.state import save_state as save

            save(sim, save_state)
        sim.apply_queued()  # what the budget deferred, before the maps are exported
        if maps_dir is not None:
            sim.export_maps(maps_dir)
        renderer.release()
        sim.close()
    finally:
        gl.release()
