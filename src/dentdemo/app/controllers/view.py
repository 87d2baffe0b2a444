"""The view: the orbit camera, the render options and quality preset, the renderer and what is
drawn of the world beside its bodies (`Scenery`); the debug views' keys and the close-up."""

from __future__ import annotations

import math
from pathlib import Path

import moderngl
import numpy as np
from numpy.typing import NDArray

from dentdemo.app.controllers import Keys
from dentdemo.app.describe import describe
from dentdemo.app.scenery import Scenery
from dentdemo.app.simulation import Simulation
from dentdemo.render.camera import OrbitCamera
from dentdemo.render.frame import RenderOptions
from dentdemo.render.quality import Quality, preset
from dentdemo.render.renderer import Renderer

#: The close-up camera: this far from the last hit, this far above its surface.
CLOSE_UP_DISTANCE = 0.3  # m
CLOSE_UP_ELEVATION_DEG = 40.0
#: Radians of orbit per pixel dragged; the wheel's zoom factor per step.
ORBIT_PER_PIXEL = 0.005
ZOOM_PER_STEP = 0.9


class ViewController:
    """How the world is seen: camera, options, quality and the renderer."""

    def __init__(self, sim: Simulation, size: tuple[int, int], quality: str | None) -> None:
        self.sim = sim
        self.gl = sim.gl
        #: What is drawn of the sim's bodies and never simulated (plate sides, images, levels).
        self.scenery = Scenery(sim.gl)
        #: The render quality preset (None: low on a software rasteriser, high on a GPU).
        self.quality = preset(quality, sim.gl.software)
        self.renderer = Renderer(sim.gl, size, self.quality)
        c = sim.scene.camera
        self.camera = OrbitCamera.from_eye(c.eye, c.target, c.fov_deg)
        self.options = RenderOptions()

    def keys(self) -> Keys:
        return {
            "1": lambda: self.set_view(0),
            "2": lambda: self.set_view(1),
            "3": lambda: self.set_view(2),
            "w": lambda: self.toggle("wireframe"),
            "c": lambda: self.toggle("contacts"),
            "a": lambda: self.toggle("address_map"),
            "x": lambda: self.toggle("parallax"),
            "f": self.close_up,
        }

    def set_view(self, view: int) -> None:
        """0 shaded, 1 height map, 2 normal map."""
        self.options.view = int(view) if view in (0, 1, 2) else 0

    def toggle(self, name: str) -> bool:
        """Flip a boolean render option (parallax, wireframe, contacts, address_map, shadows)."""
        value = not getattr(self.options, name)
        setattr(self.options, name, value)
        return value

    def orbit(self, dx_pixels: float, dy_pixels: float) -> None:
        self.camera.orbit(-dx_pixels * ORBIT_PER_PIXEL, dy_pixels * ORBIT_PER_PIXEL)

    def pan(self, dx_pixels: float, dy_pixels: float) -> None:
        h = self.renderer.size[1]
        self.camera.pan(dx_pixels / h, dy_pixels / h)

    def zoom(self, steps: float) -> None:
        self.camera.zoom(math.pow(ZOOM_PER_STEP, steps))

    def ray(self, ndc_x: float, ndc_y: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The view ray through a screen point (normalised device coordinates): origin and unit
        direction, world metres."""
        return self.camera.ray(ndc_x, ndc_y, self.renderer.aspect)

    def close_up(self) -> bool:
        """Frame the last hit (key F, panel "close-up"): the camera 0.3 m from it, 40 degrees
        above the contact plane on its upper side, keeping the current heading. False before
        any hit."""
        if self.sim.last_hit is None:
            return False
        hit = self.sim.last_hit.impact  # its normal points out of body A, towards B
        n = hit.normal / max(float(np.linalg.norm(hit.normal)), 1e-12)
        if n[1] < 0:  # both bodies are dented: look from the open side, the upper one
            n = -n
        # Keep the current heading, projected into the dented surface's plane.
        heading = self.camera.eye - self.camera.target
        heading -= n * float(heading @ n)
        if np.linalg.norm(heading) < 1e-9:
            helper = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
            heading = helper - n * float(helper @ n)
        heading /= np.linalg.norm(heading)
        e = math.radians(CLOSE_UP_ELEVATION_DEG)
        eye = hit.point + CLOSE_UP_DISTANCE * (math.cos(e) * heading + math.sin(e) * n)
        self.camera = OrbitCamera.from_eye(eye, hit.point, self.camera.fov_deg)
        return True

    def last_dent_text(self) -> str:
        """The last hit's deeper dent, for the panel: depth in millimetres and the body."""
        hit = self.sim.last_hit
        if hit is None:
            return "no dent yet"
        body, depth = hit.deepest()
        return f"last dent {depth * 1e3:.2f} mm deep in {body}"

    def set_quality(self, name: str) -> None:
        """Switch the render quality preset (panel "quality"); the scene is left as it is."""
        if name != self.quality.name:
            self.quality = preset(name, self.gl.software)
            self.renderer = _renewed(self.renderer, self.renderer.size, self.quality)

    def resize(self, size: tuple[int, int]) -> bool:
        """A renderer of the new size (not of an empty one); whether it changed."""
        if size == self.renderer.size or min(size) <= 0:
            return False
        self.renderer = _renewed(self.renderer, size, self.quality)
        return True

    def render(self, target: moderngl.Framebuffer | None = None) -> moderngl.Framebuffer:
        """Describe and draw the frame into `target` (default: the renderer's output)."""
        # The address-map view shows pass 2, which convex targets otherwise leave out.
        self.sim.draw_every_address(self.options.address_map)
        frame = describe(self.sim, self.scenery, self.camera, self.options)
        return self.renderer.render(frame, target)

    def screenshot(self, path: Path) -> Path:
        """The scene (no panel) as a PNG."""
        from dentdemo.outputs import write_png

        self.render()
        write_png(path, self.renderer.read_rgb())
        return path

    def release(self) -> None:
        self.scenery.release()
        self.renderer.release()


def _renewed(old: Renderer, size: tuple[int, int], quality: Quality) -> Renderer:
    """A renderer of `size` and `quality` in place of `old` (released)."""
    old.release()
    return Renderer(old.gl, size, quality)
