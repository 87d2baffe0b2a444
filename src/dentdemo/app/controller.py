"""The demo without a window: `DemoController` coordinates one controller per feature
(app/controllers/), so the window is a thin shell over it and tests drive it headless. It keeps
what the features share: the Simulation, the panel's values, the status line, and the keys of
them all; and it runs the simulation itself (pause, step, reset, time scale)."""

from __future__ import annotations

from pathlib import Path

from dentdemo.app import heap, inputs
from dentdemo.app.controllers import Keys
from dentdemo.app.controllers.editor import EditorController
from dentdemo.app.controllers.export import ExportController
from dentdemo.app.controllers.recording import RecordingController
from dentdemo.app.controllers.reload import ReloadController
from dentdemo.app.controllers.state import StateController
from dentdemo.app.controllers.tools import ToolsController
from dentdemo.app.controllers.undo import UndoController
from dentdemo.app.controllers.view import ViewController
from dentdemo.app.inputs import PanelState
from dentdemo.app.rate import RealRate
from dentdemo.app.simulation import Simulation
from dentdemo.app.status import Status
from dentdemo.gl.context import GLContext
from dentdemo.model.materials import MaterialLibrary
from dentdemo.model.scene import Scene
from dentdemo.render.camera import OrbitCamera

__all__ = ["DemoController", "PanelState"]


class DemoController:
    """The sandbox: the Simulation, the panel, the status line and the feature controllers."""

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
        self.sim = Simulation(gl, scene, materials, denting=denting)
        self.panel = PanelState()
        self.status = Status()
        self.paused = False
        #: Simulated seconds per wall second over the last frames (the panel shows it).
        self.rate = RealRate()
        self.view = ViewController(self.sim, size, quality)
        self.reload = ReloadController(self.sim, self.status)
        self.editor = EditorController(self.sim, self.panel, self.status, self.reload)
        self.state = StateController(self.sim, self.status)
        self.undo = UndoController(self.sim, self.status)
        self.export = ExportController(self.sim, self.status)
        self.tools = ToolsController(self.sim, self.view, self.panel)
        self.recording = RecordingController(self.sim, self.view, self.status)

    @property
    def message(self) -> str:
        """The last action's outcome, one line for the panel and the window's title."""
        return self.status.line

    def keys(self) -> Keys:
        """Every key of every feature, by name (`press`); a name is one feature's."""
        own: Keys = {"space": self.toggle_pause, "n": self.single_step, "r": self.reset}
        features = (self.view, self.reload, self.editor, self.state, self.undo, self.export)
        for feature in (*features, self.tools, self.recording):
            taken = own.keys() & feature.keys().keys()
            assert not taken, f"keys {sorted(taken)} taken twice"
            own.update(feature.keys())
        return own

    def press(self, key: str) -> bool:
        """Run the action of a key by name ("space", "f5", "ctrl+z", "1"); False when no
        feature has that key."""
        action = self.keys().get(key)
        if action is None:
            return False
        action()
        return True

    # -- the simulation ------------------------------------------------------------------------
    def update(self, wall_seconds: float) -> int:
        """Advance by wall time (scaled by the time scale) unless paused; returns steps taken.
        At most a few steps a frame: slow frames fall behind real time (`rate` measures it)."""
        steps = 0 if self.paused else self.sim.advance(wall_seconds)
        self.rate.add(wall_seconds, steps * self.sim.scene.physics.dt)
        return steps

    def toggle_pause(self) -> None:
        self.paused = not self.paused

    def single_step(self) -> None:
        """One physics step (pauses first, as a debugger's step does)."""
        self.paused = True
        self.sim.step()

    def reset(self) -> None:
        """Back to the scene as loaded; after a valid edit of the watched scene file, to the
        file as it is now (its camera too, when the edit changed it)."""
        scene = self.reload.new_scene()
        if scene is not None:
            if scene.camera != self.sim.scene.camera:
                c = scene.camera
                self.view.camera = OrbitCamera.from_eye(c.eye, c.target, c.fov_deg)
            self.sim.scene = scene
            self.status.say(f"reset to the new {self.reload.scene_file}")
        self.sim.reset()
        heap.settle()  # the old scene's cycles collected, the new one frozen (app/heap.py)

    def set_time_scale(self, scale: float) -> None:
        """x real time, clamped to inputs.TIME_SCALE; NaN is refused (the scale stays)."""
        self.sim.time_scale = inputs.clamped(scale, inputs.TIME_SCALE, self.sim.time_scale)

    def set_panel(self, name: str, value: float) -> float:
        """A typed panel value (ball_radius, throw_speed, plate_side), clamped to the scene
        files' bounds; NaN is refused. Returns the value kept."""
        kept = inputs.panel_value(name, value, getattr(self.panel, name))
        setattr(self.panel, name, kept)
        return kept

    def resize(self, size: tuple[int, int]) -> None:
        """The window's new size: a new renderer, and a recording finished (a video keeps one
        size: what was recorded is kept)."""
        if size != self.view.renderer.size and min(size) > 0:
            self.recording.stop()
            self.view.resize(size)

    def stats_line(self, fps: float) -> str:
        s = self.sim.stats
        return (
            f"{fps:5.1f} fps | {self.view.quality.name} | physics {s.physics_ms:5.2f} ms | "
            f"carve {s.carve_ms_per_hit:5.2f} ms/hit | "
            f"hits {s.hits} | queued {len(self.sim.queue)} | bodies {len(self.sim.bodies)}"
        )

    def screenshot(self, path: Path) -> Path:
        """The scene (no panel) as a PNG."""
        return self.view.screenshot(path)

    def close(self) -> None:
        self.recording.stop()
        self.tools.release()
        self.view.release()
        self.sim.close()
