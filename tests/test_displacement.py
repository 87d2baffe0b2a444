"""Displacement where dents are deep (issue 21): the outline and the shadow follow the dent.

The oracle: a ball of radius R pressed d by a box face is a sphere cut flat by a plane, so seen
from the side (orthographic) its outline is R + (R - d) = 2R - d high, flat on top over the chord
2 sqrt(2 R d - d^2), and round below. Sizes are measured on the PNG of `indent --render` by
coverage (alpha is 1 on the body, 0 on the background, fractional on MSAA edges); the image's
scale comes from the same PNG: the widest row is the equator, 2R wide."""

from __future__ import annotations

import json
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from cli_helpers import dentdemo

R, D = 0.05, 0.0125  # ball radius, press depth, m
CHORD = 2.0 * np.sqrt(2.0 * R * D - D * D)  # m


def _press_render(
    tmp_path: Path,
    *flags: str,
    quality: str = "high",
    env: dict[str, str] | None = None,
    depth: float = D,
) -> tuple[np.ndarray, dict]:
    """`indent` a 0.2 m box 12.5 mm into a 5 cm ball and `--render` it at 1280x720: the PNG's
    alpha in [0, 1], rows top-down, and the summary's "render"."""
    out = tmp_path / "press"
    png = tmp_path / "side.png"
    result = dentdemo(
        *("indent", "--tool", "box", "--tool-size", "0.2", "--target", "sphere"),
        *("--target-size", R, "--depth", depth, "--map-size", "1024", "--out", out),
        *("--render", png, "--quality", quality, *flags),
        env={**os.environ, **(env or {})},
    )
    assert result.returncode == 0, result.stderr
    image = np.asarray(Image.open(png))
    assert image.shape == (720, 1280, 4)
    summary = json.loads((out / "summary.json").read_text())["render"]
    return image[:, :, 3].astype(np.float64) / 255.0, summary


def _outline(alpha: np.ndarray) -> tuple[float, float, float]:
    """(pixels per metre, height of the outline, width of its flat top), pixels. The top edge of
    each column is its first covered row less that pixel's coverage; the flat top is the columns
    whose top edge lies within half a pixel of the highest."""
    scale = alpha.sum(axis=1).max() / (2.0 * R)
    height = alpha.sum(axis=0).max()  # the middle column's coverage: top to bottom
    tops = []
    for column in alpha.T:
        covered = np.nonzero(column > 0)[0]
        if len(covered):
            tops.append(covered[0] + 1.0 - column[covered[0]])
    top = np.asarray(tops)
    flat = float(np.count_nonzero(top - top.min() < 0.5))
    return scale, float(height), flat


@pytest.mark.parametrize(
    "path, quality",
    # The fallback at medium: at high it draws 1.8 million triangles here, 6 s on llvmpipe.
    [("tessellation", "high"), ("mesh", "medium")],
)
@pytest.mark.slow
def test_a_ball_cut_by_a_box_shows_the_exact_chord(gl, tmp_path, path, quality):
    _need(gl, path)
    alpha, summary = _press_render(
        tmp_path, "--displace", quality=quality, env={"DENTDEMO_DISPLACEMENT": path}
    )
    assert summary["displacement"] == path
    scale, height, flat = _outline(alpha)
    edges = np.concatenate([alpha[0], alpha[-1], alpha[:, 0], alpha[:, -1]])
    assert edges.max() == 0.0 and 2 * R * scale > 0.8 * 720  # whole, and large, in frame
    assert abs(height - (2 * R - D) * scale) < 1.0  # pixels
    assert abs(flat - CHORD * scale) < 2.0  # pixels (441 here)


def _need(gl, path: str) -> None:
    """Tessellation needs GL 4.0: a driver that gives only 3.3 (none here) has the fallback."""
    if path == "tessellation" and gl.ctx.version_code < 400:
        pytest.skip(f"GL 4.0 tessellation is absent: this context is {gl.ctx.version_code}")


@pytest.mark.parametrize("path, quality", [("tessellation", "high"), ("mesh", "medium")])
@pytest.mark.slow
def test_a_cut_across_the_chart_seams_has_no_crack(gl, path, quality):
    """Pressed R/3, the cut reaches 48.2 degrees from the top, past the cube-sphere's chart seams
    at 45: triangles on either side of a seam sample different charts of the map, and triangles
    of different levels meet. Seen from above (orthographic), a crack would show the background
    (the far side's inside is culled): every pixel whose centre is within the ball's radius, less
    2.5 px (medium's stretch blurs the rim), is covered, at 640x640 with 0.06 m from the centre to
    the top edge. Before seam twins (render/seams.py) 711 pixels along the seams were not."""
    _need(gl, path)
    from dentdemo.app.press import make_setup, run_presses
    from dentdemo.model.scene import LightSpec
    from dentdemo.model.shapes import Box, Sphere
    from dentdemo.render.camera import SideCamera
    from dentdemo.render.frame import DrawItem, FrameDescription, RenderOptions
    from dentdemo.render.quality import PRESETS
    from dentdemo.render.renderer import Renderer
    from dentdemo.render.side_view import LOOK

    setup = make_setup(gl, Sphere(R), Box((0.2, 0.2, 0.2)), 1024, 64)
    run_presses(gl, setup, R / 3, 0.0, 1)
    target = setup.target
    down = SideCamera(np.array([0.0, 1.0, 0.0]), np.zeros(3), np.array([0.0, 0.0, -1.0]), 0.06)
    item = DrawItem(target.gpu_mesh, target.model, LOOK, target.maps)
    options = RenderOptions(shadows=False)
    description = FrameDescription([item], down, LightSpec(), options, None, background=(1, 1, 1))
    renderer = Renderer(gl, (640, 640), PRESETS[quality], displacement=path)
    try:
        renderer.render(description)
        alpha = gl.read_framebuffer(renderer.output, components=4)[:, :, 3]
    finally:
        renderer.release()
        target.maps.release()
        setup.tool.maps.release()
    pixels = np.arange(640) + 0.5 - 320
    radius = np.hypot(pixels[:, None], pixels[None, :]) / (640 / (2 * 0.06))  # m
    inside = radius < R - 2.5 * 0.12 / 640
    assert np.count_nonzero(alpha[inside] < 255) == 0


@pytest.mark.slow
def test_the_low_preset_moves_the_mesh_vertices(tmp_path):
    """No cuts at low (no tessellation stages, whatever GL offers): the press mesh's own
    vertices (1.6 mm apart here, 11 px) move, and the outline is cut all the same, though the
    quarter-size shading stretched to 1280x720 blurs its corners."""
    alpha, summary = _press_render(tmp_path, quality="low")
    assert summary["displacement"] == "mesh"
    scale, height, _ = _outline(alpha)
    assert abs(height - (2 * R - D) * scale) < 1.5


@pytest.mark.slow
def test_without_displacement_the_outline_stays_round(tmp_path):
    alpha, summary = _press_render(tmp_path, "--no-displace")
    assert summary["displacement"] is None
    scale, height, flat = _outline(alpha)
    assert abs(height - 2 * R * scale) < 1.0
    # A circle's top lies within half a pixel of its highest point over 2 sqrt(R_px) pixels.
    assert flat < 3.0 * np.sqrt(R * scale) < CHORD * scale / 4


@pytest.mark.slow
def test_the_shadow_pass_displaces_too(gl):
    """The sun straight down on the cut ball: the shadow map's depth over the ball's middle is the
    cut plane's (R - d above the centre), not the sphere's top (R); the light's view is
    orthographic, depth (distance - near) / (far - near) with the eye 6 m above the target."""
    from dentdemo.app.press import make_setup, run_presses
    from dentdemo.model.scene import LightSpec
    from dentdemo.model.shapes import Box, Sphere
    from dentdemo.render.camera import OrbitCamera
    from dentdemo.render.frame import DrawItem, FrameDescription, RenderOptions
    from dentdemo.render.quality import PRESETS
    from dentdemo.render.renderer import Renderer
    from dentdemo.render.side_view import LOOK

    setup = make_setup(gl, Sphere(R), Box((0.2, 0.2, 0.2)), 512, 64)
    run_presses(gl, setup, D, 0.0, 1)
    target = setup.target
    item = DrawItem(target.gpu_mesh, target.model, LOOK, target.maps)
    camera = OrbitCamera.from_eye((0.0, 0.3, 0.6), (0.0, 0.0, 0.0))
    light = LightSpec(direction=(0.0, -1.0, 0.0))
    near, far, eye = 0.1, 14.0, 6.0
    renderer = Renderer(gl, (320, 180), PRESETS["high"], displacement="tessellation")
    try:
        depths = {}
        for displace in (False, True):
            options = RenderOptions(displace=displace)
            renderer.render(FrameDescription([item], camera, light, options, ground_y=None))
            side = renderer.shadow_texture.size[0]
            depth = np.frombuffer(renderer.shadow_texture.read(), np.float32).reshape(side, side)
            depths[displace] = float(depth[side // 2, side // 2])
    finally:
        renderer.release()
        setup.target.maps.release()
        setup.tool.maps.release()
    assert depths[False] == pytest.approx((eye - R - near) / (far - near), abs=2e-5)
    assert depths[True] == pytest.approx((eye - (R - D) - near) / (far - near), abs=2e-5)


def test_refine_cuts_each_triangle_into_k_squared_on_its_plane():
    from dentdemo.mesh import primitives
    from dentdemo.render.refine import cuts_for, refine

    plate = primitives.plate(2.0, subdivisions=1)  # two triangles, y = 0, x and z in [-1, 1]
    fine = refine(plate, 4)
    assert len(fine.indices) == 2 * 16
    assert np.all(fine.positions[:, 1] == 0.0)
    # The plate's own map: x = (u - 0.5) * 2, z = (0.5 - v) * 2 at every new vertex.
    u, v = fine.uvs[:, 0], fine.uvs[:, 1]
    assert np.allclose(fine.positions[:, 0], (u - 0.5) * 2.0, atol=1e-6)
    assert np.allclose(fine.positions[:, 2], (0.5 - v) * 2.0, atol=1e-6)
    a, b, c = fine.triangle_corners()
    assert np.all(np.cross(b - a, c - a)[:, 1] > 0)  # every piece still faces +Y
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum()
    assert area == pytest.approx(4.0)
    # 1 cm edges at 1 mm a pixel want 5 segments of 2 px: the next power of two, 8.
    assert cuts_for(0.01, 0.001, 2.0, 64) == 8
    assert cuts_for(0.01, 0.001, 2.0, 4) == 4
    assert cuts_for(0.001, 0.001, 2.0, 64) == 1


@pytest.mark.slow
def test_the_path_is_chosen_at_run_time_and_shown_in_info(monkeypatch):
    from dentdemo.errors import DentdemoError
    from dentdemo.render.displacement import displacement_path

    gl45, gl33 = SimpleNamespace(version_code=450), SimpleNamespace(version_code=330)
    monkeypatch.delenv("DENTDEMO_DISPLACEMENT", raising=False)
    assert displacement_path(gl45) == "tessellation"
    assert displacement_path(gl33) == "mesh"
    monkeypatch.setenv("DENTDEMO_DISPLACEMENT", "mesh")
    assert displacement_path(gl45) == "mesh"
    monkeypatch.setenv("DENTDEMO_DISPLACEMENT", "tessellation")
    with pytest.raises(DentdemoError, match="DENTDEMO_DISPLACEMENT=tessellation.*3.3"):
        displacement_path(gl33)
    monkeypatch.setenv("DENTDEMO_DISPLACEMENT", "tesselation")
    with pytest.raises(DentdemoError, match="DENTDEMO_DISPLACEMENT: unknown path 'tesselation'"):
        displacement_path(gl45)
    monkeypatch.delenv("DENTDEMO_DISPLACEMENT")
    result = dentdemo("info")
    assert result.returncode == 0, result.stderr
    assert "Displacement: tessellation (GL 4." in result.stdout
    forced = dentdemo("info", env={**os.environ, "DENTDEMO_DISPLACEMENT": "mesh"})
    assert "Displacement: mesh (forced by DENTDEMO_DISPLACEMENT=mesh" in forced.stdout


def test_displace_flags_need_render(tmp_path):
    result = dentdemo("indent", "--depth", "0.001", "--out", tmp_path / "o", "--no-displace")
    assert result.returncode == 1
    assert result.stderr.strip() == "--no-displace: only with --render PNG"
    assert not (tmp_path / "o").exists()


#: Mesa offers no more than GL 3.3 (no tessellation stages) under these.
GL33 = {"MESA_GL_VERSION_OVERRIDE": "3.3", "MESA_GLSL_VERSION_OVERRIDE": "330"}


def test_a_gl_3_3_context_renders_and_displaces_with_the_finer_mesh(gl, tmp_path):
    """On GL 3.3 (issue 41, item 6) every render failed building the tessellation variant it
    never draws with. Now `info` says the finer mesh; the sandbox's render exits 0 with the same
    picture GL 4.5 gives without displacement (the same shaders: the flat variant); and the
    displaced press is drawn by the finer mesh, its outline the exact chord."""
    if "mesa" not in gl.version.lower():
        pytest.skip(f"the override is Mesa's: this driver is {gl.version}")
    env = {**os.environ, **GL33}
    info = dentdemo("info", env=env)
    assert info.returncode == 0, info.stderr
    assert "GL version:  3.3" in info.stdout
    assert "Displacement: mesh, a finer render mesh (GL 3.3 has no tessellation" in info.stdout
    pictures = []
    for name, run_env in (("gl33.png", env), ("gl45.png", None)):
        result = dentdemo(
            *("render", "--frames", "2", "--out", tmp_path / name, "--no-displace"), env=run_env
        )
        assert result.returncode == 0, result.stderr
        pictures.append(np.asarray(Image.open(tmp_path / name).convert("RGB"), np.float64))
    gl33, gl45 = pictures
    assert gl33.std(axis=(0, 1)).min() > 10.0  # a scene, not a cleared frame
    assert np.abs(gl33 - gl45).max() <= 2.0
    alpha, summary = _press_render(tmp_path, "--displace", quality="medium", env=GL33)
    assert summary["displacement"] == "mesh"
    scale, height, flat = _outline(alpha)
    assert abs(height - (2 * R - D) * scale) < 1.0  # pixels
    assert abs(flat - CHORD * scale) < 2.0  # pixels
