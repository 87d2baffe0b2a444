"""The demo's logic without a window: every panel action and key is a method here, so the window
is a thin shell over it and tests drive it headless."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import moderngl
import numpy as np

from dentdemo.app import inputs
from dentdemo.app.describe import describe
from dentdemo.app.simulation import Simulation
from dentdemo.gl.context import GLContext
from dentdemo.model.materials import MaterialLibrary
from dentdemo.model.scene import BodySpec, Scene
from dentdemo.model.shapes import Plate
from dentdemo.render.camera import OrbitCamera
from dentdemo.render.frame import RenderOptions
from dentdemo.render.quality import preset
from dentdemo.render.renderer import Renderer

DROP_HEIGHT = 1.0  # m above the clicked point
#: The close-up camera: this far from the last hit, this far above its surface.
CLOSE_UP_DISTANCE = 0.3  # m
CLOSE_UP_ELEVATION_DEG = 40.0
#: Where the demo's save-state key and button write, and load-state reads (a folder).
STATE_DIR = Path("dentdemo_state")
#: Where the demo's glTF key and button write by default (`demo --gltf` changes it).
GLTF_FILE = Path("dentdemo.glb")


@dataclass
class PanelState:
    """What the control panel sets."""

    ball_material: str = "steel"
    ball_radius: float = 0.04  # m
    throw_speed: float = 6.0  # m/s
    plate_material: str = "aluminium"
    plate_side: float = 0.5  # m


class DemoController:
    """The sandbox's state and actions: the Simulation, the renderer, the camera, the panel."""

    def __init__(
        self,
        gl: GLContext,
        scene: Scene,
        materials: MaterialLibrary,
        size: tuple[int, int],
        *,
        denting: bool = True,
        quality: str | None = None,
    ) -> None:
        self.gl = gl
        self.materials = materials
        self.sim = Simulation(gl, scene, materials, denting=denting)
        #: The render quality preset (None: low on a software rasteriser, high on a GPU).
        self.quality = preset(quality, gl.software)
        self.renderer = Renderer(gl, size, self.quality)
        self.camera = OrbitCamera.from_eye(
            scene.camera.eye, scene.camera.target, scene.camera.fov_deg
        )
        self.options = RenderOptions()
        self.panel = PanelState()
        self.paused = False
        self._plates = 0
        #: The last save/load/export outcome, one line for the panel and the window title.
        self.message = ""
        #: Where `export_gltf` writes (key G, the panel's button).
        self.gltf_path = GLTF_FILE

    # -- simulation ----------------------------------------------------------------------------
    def update(self, wall_seconds: float) -> int:
        """Advance by wall time (scaled by the time scale) unless paused; returns steps taken."""
        return 0 if self.paused else self.sim.advance(wall_seconds)

    def toggle_pause(self) -> None:
        self.paused = not self.paused

    def single_step(self) -> None:
        """One physics step (pauses first, as a debugger's step does)."""
        self.paused = True
        self.sim.step()

    def reset(self) -> None:
        self.sim.reset()

    def set_time_scale(self, scale: float) -> None:
        """x real time, clamped to inputs.TIME_SCALE; NaN is refused (the scale stays)."""
        self.sim.time_scale = inputs.clamped(scale, inputs.TIME_SCALE, self.sim.time_scale)

    def set_panel(self, name: str, value: float) -> float:
        """A typed panel value (ball_radius, throw_speed, plate_side), clamped to the scene
        files' bounds; NaN is refused. Returns the value kept."""
        kept = inputs.panel_value(name, value, getattr(self.panel, name))
        setattr(self.panel, name, kept)
        return kept

    def save_state(self, directory: Path = STATE_DIR) -> bool:
        """Save every body's maps and the physics state (F5, panel "save state")."""
        from dentdemo.app.state import save_state

        def save(sim: Simulation, path: Path) -> Path:
            return save_state(sim, path, "save state (F5)")

        return self._with_state(save, directory, f"saved to {directory}/")

    def load_state(self, directory: Path = STATE_DIR) -> bool:
        """Resume a saved state (F9, panel "load state"); a bad one changes nothing."""
        from dentdemo.app.state import load_state

        loaded = self._with_state(load_state, directory, f"loaded {directory}/")
        if loaded:
            self.message += "; undo history is not saved: none to undo"
        return loaded

    # -- undo and repair -----------------------------------------------------------------------
    def undo(self) -> bool:
        """Ctrl+Z, panel "undo": take back the last frame's hits (Simulation.undo)."""
        done = self.sim.undo()
        left = len(self.sim.undo_log)
        self.message = f"undid the last hits ({left} more to undo)" if done else "nothing to undo"
        return done

    def repair_target(self) -> str | None:
        """The body the panel's "repair" button repairs: the one dented deeper by the last hit
        (there is no body selection yet); None before any hit or once it is gone."""
        hit = self.sim.last_hit
        body = None if hit is None else hit.deepest()[0]
        return body if body in self.sim.bodies else None

    def repair(self, body_id: str) -> bool:
        """Panel "repair": the body's pristine maps back (Simulation.repair)."""
        if body_id not in self.sim.bodies:
            self.message = f"repair: no body {body_id!r}"
            return False
        self.sim.repair(body_id)
        self.message = f"repaired {body_id}"
        return True

    def export_gltf(self, path: Path | None = None) -> bool:
        """Write every body as it is now to glTF 2.0 (key G, panel "export glTF"), to `path` or
        `gltf_path`; the outcome becomes `message`."""
        target = path or self.gltf_path
        return self._with_state(Simulation.export_gltf, target, f"exported {target}")

    def _with_state(self, action, path: Path, done: str) -> bool:  # noqa: ANN001
        """Run a save, load or export; its outcome, or the error's one line, becomes
        `message`."""
        from dentdemo.errors import DentdemoError

        try:
            action(self.sim, path)
        except DentdemoError as exc:
            self.message = str(exc)
            return False
        self.message = f"{done} at t = {self.sim.world.time:.2f} s"
        return True

    # -- picking -------------------------------------------------------------------------------
    def ground_point(self, ndc_x: float, ndc_y: float) -> np.ndarray | None:
        """Where the view ray through a screen point meets the floor (y = 0), world metres."""
        origin, direction = self.camera.ray(ndc_x, ndc_y, self.renderer.aspect)
        if direction[1] > -1e-6:
            return None
        return origin + direction * (-origin[1] / direction[1])

    def drop_ball(self, ndc_x: float, ndc_y: float) -> str | None:
        """Left click: a ball of the panel's material and radius, 1 m above the clicked point."""
        point = self.ground_point(ndc_x, ndc_y)
        if point is None:
            return None
        p = inputs.checked(self.panel)
        return self.sim.drop_ball(
            point + [0.0, DROP_HEIGHT, 0.0], (0, 0, 0), p.ball_material, p.ball_radius
        )

    def throw_ball(self, ndc_x: float, ndc_y: float, strength: float = 1.0) -> str:
        """Right drag: a ball from the camera along the view ray at the panel's speed."""
        origin, direction = self.camera.ray(ndc_x, ndc_y, self.renderer.aspect)
        p = inputs.checked(self.panel)
        start = origin + direction * (p.ball_radius * 3 + 0.05)
        speed = p.throw_speed * float(np.clip(strength, 0.2, 3.0))
        return self.sim.drop_ball(start, direction * speed, p.ball_material, p.ball_radius)

    def add_plate(self) -> str:
        """A static plate of the panel's material on the floor under the orbit target."""
        self._plates += 1
        body_id = f"plate_{self._plates}"
        while body_id in self.sim.bodies:
            self._plates += 1
            body_id = f"plate_{self._plates}"
        t = self.camera.target
        spec = BodySpec(
            id=body_id,
            shape=Plate(inputs.checked(self.panel).plate_side, thickness=0.02),
            material=self.materials.get(self.panel.plate_material),
            position=(float(t[0]), 0.02, float(t[2])),
            static=True,
            texels_per_metre=1024,
        )
        self.sim.add_body(spec)
        return body_id

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

    # -- views ---------------------------------------------------------------------------------
    def set_view(self, view: int) -> None:
        self.options.view = int(view) if view in (0, 1, 2) else 0

    def toggle(self, name: str) -> bool:
        """Flip a boolean render option (parallax, wireframe, contacts, address_map, shadows)."""
        value = not getattr(self.options, name)
        setattr(self.options, name, value)
        return value

    def orbit(self, dx_pixels: float, dy_pixels: float) -> None:
        self.camera.orbit(-dx_pixels * 0.005, dy_pixels * 0.005)

    def pan(self, dx_pixels: float, dy_pixels: float) -> None:
        h = self.renderer.size[1]
        self.camera.pan(dx_pixels / h, dy_pixels / h)

    def zoom(self, steps: float) -> None:
        self.camera.zoom(math.pow(0.9, steps))

    # -- frames --------------------------------------------------------------------------------
    def render(self, target: moderngl.Framebuffer | None = None) -> moderngl.Framebuffer:
        """Describe and draw the frame into `target` (default: the renderer's output)."""
        return self.renderer.render(describe(self.sim, self.camera, self.options), target)

    def set_quality(self, name: str) -> None:
        """Switch the render quality preset (panel "quality"); the scene is left as it is."""
        if name != self.quality.name:
            self.quality = preset(name, self.gl.software)
            self._rebuild_renderer(self.renderer.size)

    def resize(self, size: tuple[int, int]) -> None:
        if size != self.renderer.size and min(size) > 0:
            self._rebuild_renderer(size)

    def _rebuild_renderer(self, size: tuple[int, int]) -> None:
        self.renderer.release()
        self.renderer = Renderer(self.gl, size, self.quality)

    def stats_line(self, fps: float) -> str:
        s = self.sim.stats
        return (
            f"{fps:5.1f} fps | {self.quality.name} | physics {s.physics_ms:5.2f} ms | "
            f"carve {s.carve_ms_per_hit:5.2f} ms/hit | "
            f"hits {s.hits} | queued {len(self.sim.queue)} | bodies {len(self.sim.bodies)}"
        )

    def screenshot(self, path: Path) -> Path:
        from dentdemo.outputs import write_png

        self.render()
        write_png(path, self.renderer.read_rgb())
        return path

    def close(self) -> None:
        self.renderer.release()
        self.sim.close()
