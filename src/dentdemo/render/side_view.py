"""A body seen from the side of a press, whole, on a plain background: for checking outlines by
eye and by test (`dentdemo indent --render`). The view is orthographic, so the outline's sizes
are metres times a constant pixels per metre; the background's alpha is 0, the body's 1."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dentdemo.gl.context import GLContext
from dentdemo.gpu.maps import SurfaceMaps
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.model.materials import Appearance
from dentdemo.model.scene import LightSpec
from dentdemo.render.camera import SideCamera
from dentdemo.render.frame import DrawItem, FrameDescription, RenderOptions
from dentdemo.render.quality import Quality
from dentdemo.render.renderer import Renderer

#: A plain mid-grey dielectric: outlines and dents read on it.
LOOK = Appearance(base_colour=(0.55, 0.55, 0.57), metalness=0.0, roughness=0.45)
#: sRGB of the background (alpha 0).
BACKGROUND = (0.93, 0.93, 0.93)
#: Free space around the body, as a fraction of its half extent.
MARGIN = 0.08


@dataclass(frozen=True)
class SideView:
    """The image (rows top-down, RGBA) and its scale."""

    pixels: NDArray[np.uint8]
    #: Metres per pixel, the same everywhere in the image.
    metres_per_pixel: float
    #: How the surface was displaced ("tessellation" or "mesh"), or None when not.
    displacement: str | None


def side_camera(
    points: NDArray[np.float64], press: NDArray[np.float64], aspect: float
) -> SideCamera:
    """An orthographic camera looking across `press` (the way the tool moved: it comes from the
    top of the image) at world `points`, all in frame with MARGIN to spare. It looks along the
    world axis most nearly perpendicular to the press, made exactly perpendicular."""
    down = press / np.linalg.norm(press)
    axis = np.eye(3)[int(np.argmin(np.abs(down)))]
    forward = axis - (axis @ down) * down
    forward /= np.linalg.norm(forward)
    up = -down
    right = np.cross(forward, up)
    lo = np.array([(points @ right).min(), (points @ up).min()])
    hi = np.array([(points @ right).max(), (points @ up).max()])
    mid = (lo + hi) / 2
    half = (hi - lo) / 2
    half_height = max(half[1], half[0] / aspect, 1e-6) * (1.0 + MARGIN)
    depth = points @ forward
    centre = mid[0] * right + mid[1] * up + (depth.min() + depth.max()) / 2 * forward
    reach = float(depth.max() - depth.min()) + 4.0 * half_height
    return SideCamera(centre - forward * reach, centre, up, half_height)


def render_side_view(
    gl: GLContext,
    mesh: GpuMesh,
    maps: SurfaceMaps,
    model: NDArray[np.float64],
    press: NDArray[np.float64],
    size: tuple[int, int],
    quality: Quality,
    displace: bool,
) -> SideView:
    """The body (`mesh` with `maps` at `model`, world from local) seen across `press`."""
    local = mesh.mesh.positions.astype(np.float64)
    world = local @ model[:3, :3].T + model[:3, 3]
    camera = side_camera(world, np.asarray(press, np.float64), size[0] / size[1])
    forward = camera.target - camera.eye
    forward /= np.linalg.norm(forward)
    # The sun from behind the viewer's left shoulder, above: the face towards the viewer is lit.
    sun = 0.6 * forward - 0.7 * camera.up + 0.4 * np.cross(camera.up, forward)
    light = LightSpec(direction=tuple(sun), intensity=2.0, ambient=0.45)
    renderer = Renderer(gl, size, quality)
    try:
        description = FrameDescription(
            [DrawItem(mesh, np.asarray(model, np.float64), LOOK, maps)],
            camera,
            light,
            RenderOptions(shadows=False, displace=displace),
            ground_y=None,
            background=BACKGROUND,
        )
        renderer.render(description)
        pixels = gl.read_framebuffer(renderer.output, components=4)[::-1]
        return SideView(
            np.ascontiguousarray(pixels),
            camera.metres_per_pixel(0.0, size[1]),
            renderer.displacement if displace else None,
        )
    finally:
        renderer.release()
