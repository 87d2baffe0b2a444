"""The developer tools (issue 23, item 4) through the controller: Ctrl + click selects a body and
the panel names its material, dents and deepest dent; a live view of its maps drawn on the GPU;
the profiler strip; and recording the window to an MP4 at the fixed step (a real window under
Xvfb)."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from cli_helpers import python_json
from dentdemo.app.controller import DemoController
from dentdemo.app.loop import FrameLoop, ImageBackend
from dentdemo.app.profiler import PHASES, Profiler
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
from dentdemo.render.camera import OrbitCamera
from scene_text import GROUND, ball, camera, plate

SCENE = "\n".join(
    [
        camera("[0.0, 1.0, 1.5]"),
        GROUND,
        plate("lead", texels=1024),
        ball("steel", "[0.0, 0.5, 0.0]"),
    ]
)


@pytest.fixture
def app(gl, tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    lib = load_materials()
    controller = DemoController(gl, load_scene(path, lib), lib, (320, 180))
    yield controller
    controller.close()


def _ndc(app: DemoController, point) -> tuple[float, float]:
    x, y = app.view.camera.project(
        np.array([point]), app.view.renderer.aspect, app.view.renderer.size
    )[0]
    w, h = app.view.renderer.size
    return x / w * 2 - 1, 1 - y / h * 2


def test_ctrl_click_selects_the_body_under_the_cursor(app):
    assert app.tools.select_at(*_ndc(app, (0.0, 0.5, 0.0))) == "ball"
    assert app.tools.select_at(*_ndc(app, (0.15, 0.02, 0.1))) == "plate"
    assert app.tools.select_at(*_ndc(app, (1.0, 0.0, -1.0))) == "ground"
    app.view.camera = OrbitCamera.from_eye((0.0, 0.5, 1.5), (0.0, 1.5, 0.0), 45.0)  # looking up
    assert app.tools.select_at(0.0, 0.5) is None  # the sky
    assert app.tools.selection_text() == ["nothing selected (Ctrl + click a body)"]


def test_the_selection_names_material_dents_and_the_deepest(app):
    app.tools.select_at(*_ndc(app, (0.15, 0.02, 0.1)))
    assert app.tools.selection_text() == [
        "plate: plate, lead, takes dents",
        "0 dents, deepest 0.00 mm (bound 30 mm)",
    ]
    for _ in range(90):
        app.sim.step()
    # By hand: the ball falls 0.5 - 0.02 - 0.04 = 0.44 m: v = sqrt(2 g h) = 2.938 m/s;
    # eq. 2 (eps = 1, static plate): j = 2 m v, m = 7850 * 4/3 pi 0.04^3; eq. 4 with lead's k
    # (eq. 3) and Y (eq. 5): about 8.0 mm, the first and deepest of its bounces.
    m = 7850 * 4 / 3 * math.pi * 0.04**3
    j = 2 * m * math.sqrt(2 * 9.81 * 0.44)
    depth = 2e5 * (1 / 0.3e9 - 1 / 16e9) * (j - (1 / (1 - 0.1) - 1))
    dents = app.sim.dents["plate"]
    assert dents.deepest == pytest.approx(depth, rel=0.01)
    assert dents.count == len(app.sim.carved_points) >= 1  # every carve here is in the plate
    assert app.tools.selection_text()[1] == (
        f"{dents.count} dents, deepest {dents.deepest * 1e3:.2f} mm (bound 30 mm)"
    )
    app.reset()
    assert "plate" not in app.sim.dents


def test_the_map_view_colours_heights_on_the_gpu(app, gl):
    """The height view texture shows each block's deepest texel on the height view's ramp:
    untouched grey (0.88), 2.5 mm of a 5 mm scale teal (0.10, 0.70, 0.60), 5 mm red (0.85, 0.15,
    0.10), sRGB; the normal map is the body's own texture."""
    app.tools.selected = "plate"
    maps = app.sim.bodies["plate"].maps
    side = maps.size[0]  # 0.4 m at 1024 texels per metre: 410 -> blocks of 2
    heights = np.zeros((side, side), np.float32)
    heights[0, 1] = -0.0025  # one texel, in view pixel (0, 0)
    heights[side - 2 :, side - 2 :] = -0.005  # the last block, view pixel (204, 204)
    maps.height.write(heights.tobytes())
    view, normal = app.tools.map_textures()
    assert normal is maps.normal
    image = np.frombuffer(view.read(), np.uint8).reshape(256, 256, 4)[:, :, :3] / 255.0
    block = math.ceil(side / 256)
    last = (side - 1) // block
    np.testing.assert_allclose(image[0, 0], (0.10, 0.70, 0.60), atol=1 / 255)
    np.testing.assert_allclose(image[last, last], (0.85, 0.15, 0.10), atol=1 / 255)
    np.testing.assert_allclose(image[100, 30], (0.88, 0.88, 0.88), atol=1 / 255)
    app.tools.selected = "ground"  # takes no dents: no view
    assert app.tools.map_textures() is None


@pytest.mark.slow
def test_the_profiler_keeps_the_last_seconds_of_every_phase(app):
    loop = FrameLoop(app, ImageBackend((320, 180), None), fixed_dt=True)
    loop.run(frames=6)
    assert len(app.tools.profiler) == 6
    for phase in PHASES:
        values = app.tools.profiler.series(phase)
        assert values.dtype == np.float32 and len(values) == 6
        assert np.isfinite(values).all() and (values >= 0).all()
    assert app.tools.profiler.mean("render") > 0
    strip = Profiler(seconds=5.0)
    for t in range(11):
        strip.add(float(t), (t, 2 * t, 0.0, 1.0))
    assert list(strip.series("physics")) == [5, 6, 7, 8, 9, 10]  # the last 5 s only
    assert strip.mean("carve") == 15.0


_RECORD = """
import json, sys
from pathlib import Path
from dentdemo.app.loop import FrameLoop
from dentdemo.app.window import DemoWindow
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
from dentdemo.render.camera import OrbitCamera
lib = load_materials()
window = DemoWindow(load_scene(sys.argv[1], lib), lib, (320, 180), "low")
app = window.app
app.recording.toggle(Path(sys.argv[2]))
FrameLoop(app, window, fixed_dt=False).run(frames=30)  # wall-clock stepping, but recording
steps = app.sim.stats.frames
app.recording.toggle()
print(json.dumps({"steps": steps, "t": app.sim.world.time, "message": app.message}))
window.close()
"""


@pytest.mark.slow
def test_recording_the_window_writes_an_mp4_at_the_fixed_step(xvfb, tmp_path):
    import imageio_ffmpeg

    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    out = tmp_path / "clip.mp4"
    env = {**os.environ, "DISPLAY": xvfb}
    report = python_json(_RECORD, scene, out, env=env)
    # One fixed step (1/60 s) per frame while recording, whatever the wall clock did.
    assert report["steps"] == 30
    assert report["t"] == pytest.approx(30 / 60, abs=1e-9)
    assert report["message"] == f"wrote {out} (30 frames, 0.50 s)"
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(out))
    assert frames == 30 and seconds == pytest.approx(0.5, abs=0.02)
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = next(reader)
    assert tuple(meta["size"]) == (320, 180) and meta["fps"] == pytest.approx(60.0)
    first = np.frombuffer(next(reader), np.uint8).reshape(180, 320, 3)
    assert first.std() > 10  # the scene, not a blank frame


def test_the_world_holds_nothing_only_drawn_and_scenery_follows_it(app):
    """Issue 23 item 5: the Simulation's bodies carry spec, mesh and maps only; the plate's sides
    and curved bodies' coarser levels are the Scenery's, made on the first frame, kept across a
    reset while the shape is the same, released when a body goes."""
    from dataclasses import fields

    from dentdemo.app.simulation import SimBody

    assert [f.name for f in fields(SimBody)] == ["spec", "mesh", "gpu_mesh", "maps"]
    assert app.view.scenery.parts == {}
    app.view.render()
    parts = app.view.scenery.parts
    assert set(parts) == set(app.sim.bodies)
    sides = parts["plate"].under
    assert sides is not None and parts["ball"].under is None and parts["ball"].coarser
    # The sides span the plate's 0.4 m, from its top face (no lid) to 0.02 m below (body space).
    box = sides.mesh.positions
    np.testing.assert_allclose(box.max(axis=0)[[0, 2]], [0.2, 0.2], atol=1e-9)
    assert box[:, 1].min() == pytest.approx(-0.02, abs=1e-7)
    assert box[:, 1].max() == pytest.approx(0.0, abs=1e-7)
    faces_up = sides.mesh.normals[sides.mesh.indices[:, 0], 1] > 0.5
    assert not faces_up.any()  # the top face is the dentable plate's own
    app.reset()
    app.view.render()
    assert app.view.scenery.parts["plate"].under is sides  # the same shape: kept
    ball = app.sim.drop_ball((0.1, 0.4, 0.0), radius=0.03)
    app.view.render()
    assert ball in app.view.scenery.parts
    app.sim.remove_body(ball)
    app.view.render()
    assert ball not in app.view.scenery.parts
