"""The close-up of issue 13's visibility oracle: a 5 cm steel ball pressed 1 mm into an aluminium
plate, seen from 0.3 m away and 40 degrees above the plate, rendered with and without the dent;
and the dent's footprint projected into the image (analytic: a disc of radius sqrt(2 R d - d^2))."""

from __future__ import annotations

import math

import numpy as np

from dentdemo.app.press import make_setup
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import LightSpec
from dentdemo.model.shapes import Plate, Sphere
from dentdemo.render.camera import OrbitCamera
from dentdemo.render.frame import DrawItem, FrameDescription, RenderOptions
from dentdemo.render.renderer import Renderer

RADIUS, DEPTH = 0.05, 0.001  # m
ALUMINIUM = load_materials().get("aluminium").appearance
DISTANCE, ELEVATION_DEG = 0.3, 40.0
SIZE = (640, 480)


def camera() -> OrbitCamera:
    e = math.radians(ELEVATION_DEG)
    eye = np.array([0.0, math.sin(e), math.cos(e)]) * DISTANCE  # looking along -z, down 40 deg
    return OrbitCamera.from_eye(eye, np.zeros(3), 35.0)


def footprint_mask(cam: OrbitCamera, size=SIZE, depth: float = DEPTH) -> np.ndarray:
    """Pixels whose centre sees a plate point inside the disc where the ball's cap is deeper
    than DEPTH - `depth` (the dent's whole disc by default; ray-plane intersection)."""
    w, h = size
    ys, xs = np.mgrid[0:h, 0:w] + 0.5
    ndc_x, ndc_y = xs / w * 2 - 1, 1 - ys / h * 2
    inverse = np.linalg.inv(cam.view_proj(w / h))
    near = np.stack([ndc_x, ndc_y, -np.ones_like(xs), np.ones_like(xs)], -1) @ inverse.T
    far = np.stack([ndc_x, ndc_y, np.ones_like(xs), np.ones_like(xs)], -1) @ inverse.T
    a, b = near[..., :3] / near[..., 3:], far[..., :3] / far[..., 3:]
    t = -a[..., 1] / (b[..., 1] - a[..., 1])
    hit = a + t[..., None] * (b - a)
    r = math.sqrt(2 * RADIUS * depth - depth**2)
    return np.hypot(hit[..., 0], hit[..., 2]) < r


def render_closeup(
    gl, dented: bool, options: RenderOptions | None = None, look=ALUMINIUM, **renderer_kw
):
    """The close-up as uint8 [rows top-down, cols, 3], the plate drawn with `look`."""
    setup = make_setup(gl, Plate(0.5), Sphere(RADIUS), 2048, 256, max_dent_depth=0.015)
    try:
        if dented:
            from dentdemo.carve.carver import Carver

            carver = Carver(gl)
            carver.carve(setup.target, setup.tool, setup.contact, DEPTH, 0.0)
            carver.release()
        renderer = Renderer(gl, SIZE, **renderer_kw)
        frame = FrameDescription(
            [DrawItem(setup.target.gpu_mesh, np.eye(4), look, setup.target.maps)],
            camera(),
            LightSpec(),
            options or RenderOptions(),
            ground_y=-0.02,  # the plate is 2 cm thick, on the ground
        )
        renderer.render(frame)
        image = renderer.read_rgb()
        renderer.release()
        return image
    finally:
        for body in (setup.target, setup.tool):
            body.maps.release()
            body.gpu_mesh.release()


def visible_fraction(gl, **kw) -> tuple[float, np.ndarray, np.ndarray]:
    """Share of footprint pixels that change by 10 or more sRGB levels (any channel)."""
    plain = render_closeup(gl, False, **kw).astype(int)
    dent = render_closeup(gl, True, **kw).astype(int)
    mask = footprint_mask(camera())
    changed = np.abs(dent - plain).max(axis=2) >= 10
    return float(changed[mask].mean()), plain, dent
