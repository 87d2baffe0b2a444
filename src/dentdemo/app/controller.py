"""The demo's logic without a window: every panel action and key is a method here, so the window
is a thin shell over it and tests drive it headless."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import moderngl
import numpy as np

from dentdemo import log
from dentdemo.app import heap, inputs
from dentdemo.app.describe import describe
from dentdemo.app.editor import MaterialEditor, PredictedDent, predict_dent, with_preset
from dentdemo.app.map_view import MapView
from dentdemo.app.profiler import Profiler
from dentdemo.app.scenery import Scenery
from dentdemo.app.simulation import Simulation
from dentdemo.app.video import VideoFile
from dentdemo.app.watch import FileWatcher
from dentdemo.errors import DentdemoError
from dentdemo.gl.context import GLContext
from dentdemo.model.materials import MaterialLibrary, load_materials, reloaded_line
from dentdemo.model.scene import BodySpec, Scene, load_scene
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
#: Where the material editor saves when the demo was given no --materials file.
MATERIALS_FILE = Path("dentdemo_materials.toml")
#: The panel's plates ("add plate at target"), and the ones the predicted dents are for, m.
PLATE_THICKNESS = 0.02


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
        #: What is drawn of the sim's bodies and never simulated (plate sides, images, levels).
        self.scenery = Scenery(gl)
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
        #: The user's materials files and the scene file, watched once `watch` was called.
        self.material_files: tuple[Path, ...] = ()
        self.scene_file: Path | None = None
        self._watcher: FileWatcher | None = None
        #: The scene file changed on disk (and is valid): `reset` loads it.
        self.scene_changed = False
        #: The body the developer tools look at (Ctrl + click), or None.
        self.selected: str | None = None
        #: The last seconds of frame phases (the frame loop adds each frame).
        self.profiler = Profiler()
        #: The video being recorded from the window (F6), or None.
        self.recorder: VideoFile | None = None
        self._map_view: MapView | None = None
        #: The panel's material editor, on the ball's preset to begin with.
        self.editor = MaterialEditor(materials, self.panel.ball_material)

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
        """Back to the scene as loaded; after a valid edit of the watched scene file, to the
        file as it is now (its camera too, when the edit changed it)."""
        if self.scene_changed and self.scene_file is not None:
            try:
                scene = load_scene(self.scene_file, self.materials)
            except DentdemoError as exc:
                self._report_error(exc)  # edited again since, into something invalid
            else:
                if scene.camera != self.sim.scene.camera:
                    c = scene.camera
                    self.camera = OrbitCamera.from_eye(c.eye, c.target, c.fov_deg)
                self.sim.scene = scene
                self.scene_changed = False
                self.message = f"reset to the new {self.scene_file}"
        self.sim.reset()
        heap.settle()  # the old scene's cycles collected, the new one frozen (app/heap.py)

    # -- hot reload ----------------------------------------------------------------------------
    def watch(self, material_files: Sequence[Path], scene_file: Path | None) -> None:
        """Watch the user's materials files and the scene file: `poll_files` (each frame)
        applies a saved change to the materials and offers a reset to a changed scene."""
        self.material_files = tuple(Path(p) for p in material_files)
        self.scene_file = None if scene_file is None else Path(scene_file)
        watched = self.material_files + (() if self.scene_file is None else (self.scene_file,))
        self._watcher = FileWatcher(watched)

    def poll_files(self, now: float | None = None) -> list[str]:
        """Look at the watched files (at most every POLL_INTERVAL seconds of `now`, default the
        monotonic clock) and act on what changed; returns the lines reported (stderr and
        `message`): `dentdemo: reloaded F (N materials)`, or the one-line error that the same
        file would give at start-up, the last good values kept."""
        if self._watcher is None:
            return []
        changed = self._watcher.poll(time.monotonic() if now is None else now)
        lines: list[str] = []
        edited = [path for path in changed if path in self.material_files]
        if edited:
            lines += self._reload_materials(edited)
        if self.scene_file in changed:
            lines.append(self._scene_edited(self.scene_file))
        return lines

    def _reload_materials(self, edited: list[Path]) -> list[str]:
        """Load every materials file again after a save of `edited` ones: one line each, or the
        first error's line and nothing changed."""
        try:
            materials = load_materials(self.material_files)
            self.sim.set_materials(materials, str(edited[0]))
        except DentdemoError as exc:
            return [self._report_error(exc)]
        before, self.materials = self.materials, materials
        name = self.editor.name if self.editor.name in materials.materials else None
        self.editor.select(materials, name or self.panel.ball_material)
        if self.scene_changed and self.scene_file is not None:
            self._scene_edited(self.scene_file)  # the new scene with the new presets
        return [self._report(reloaded_line(before, materials, str(path))) for path in edited]

    # -- material editor -----------------------------------------------------------------------
    def edit_material(self, key: str, value: object) -> bool:
        """Set one key of the edited preset (None removes an optional key). A valid draft is
        used at once, by every body of that preset and by new ones; an invalid one leaves the
        last valid preset in use, the validator's line in `editor.error`."""
        preset = self.editor.set(key, value)
        if preset is None:
            return False
        self.materials = with_preset(self.materials, preset)
        self.editor.library = self.materials
        self.sim.set_materials(self.materials)
        return True

    def predicted_dents(self) -> list[PredictedDent]:
        """The dent a ball of the panel's material and radius, thrown at the panel's speed
        straight onto a plate, leaves in each preset as the plate and in the ball."""
        p = self.panel
        ball = self.materials.get(p.ball_material)
        return [
            predict_dent(
                ball, p.ball_radius, p.throw_speed, self.materials.materials[name], PLATE_THICKNESS
            )
            for name in self.materials.names()
        ]

    def save_materials(self) -> bool:
        """Write the edited preset into the user's materials file (the last --materials file;
        without one, `MATERIALS_FILE`, watched from then on), keeping its comments and order;
        the shipped presets are never written. The outcome becomes `message`."""
        from dentdemo.app.materials_save import save_preset

        path = self.material_files[-1] if self.material_files else MATERIALS_FILE
        try:
            save_preset(path, self.editor.name, self.editor.draft, self.materials.calibration)
        except DentdemoError as exc:
            self._report_error(exc)
            return False
        if path not in self.material_files:
            self.watch((*self.material_files, path), self.scene_file)
        self.message = f"saved [materials.{self.editor.name}] to {path}"
        return True

    def _scene_edited(self, path: Path) -> str:
        try:
            scene = load_scene(path, self.materials)
        except DentdemoError as exc:
            self.scene_changed = False
            return self._report_error(exc)
        self.scene_changed = True
        return self._report(
            f"dentdemo: {path} changed ({len(scene.bodies)} bodies): reset (R) to load it"
        )

    def _report(self, line: str) -> str:
        """An outcome of the hot reload: one stderr line (silenced by --quiet) and `message`."""
        log.warn(line)
        self.message = line
        return line

    def _report_error(self, exc: DentdemoError) -> str:
        """A bad edit: the start-up error's one line on stderr and in `message`."""
        line = str(exc).splitlines()[0]
        print(line, file=sys.stderr)
        self.message = line
        return line

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
            heap.settle()  # as after a reset (app/heap.py)
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
            shape=Plate(inputs.checked(self.panel).plate_side, thickness=PLATE_THICKNESS),
            material=self.materials.get(self.panel.plate_material),
            position=(float(t[0]), 0.02, float(t[2])),
            static=True,
            texels_per_metre=1024,
        )
        self.sim.add_body(spec)
        return body_id

    def select_at(self, ndc_x: float, ndc_y: float) -> str | None:
        """Ctrl + click: select the body under a screen point (the first its view ray meets,
        by the collision shapes), or nothing."""
        origin, direction = self.camera.ray(ndc_x, ndc_y, self.renderer.aspect)
        self.selected = self.sim.world.ray_pick(origin, direction)
        return self.selected

    def selection_text(self) -> list[str]:
        """The selected body for the panel: name, material, dent count and deepest dent."""
        body = self.sim.bodies.get(self.selected) if self.selected else None
        if body is None:
            return ["nothing selected (Ctrl + click a body)"]
        dents = self.sim.dents.get(body.spec.id)
        count, deepest = (dents.count, dents.deepest) if dents else (0, 0.0)
        what = "takes dents" if body.spec.dentable else "takes no dents"
        return [
            f"{body.spec.id}: {type(body.spec.shape).__name__.lower()}, "
            f"{body.spec.material.name}, {what}",
            f"{count} dents, deepest {deepest * 1e3:.2f} mm "
            f"(bound {body.spec.material.max_dent_depth * 1e3:.0f} mm)",
        ]

    def map_textures(self) -> tuple[moderngl.Texture, moderngl.Texture] | None:
        """The selected body's maps for the panel, redrawn now on the GPU: its heights coloured
        as the height view colours them (RGBA8), and its normal map itself. None when nothing
        that takes dents is selected."""
        body = self.sim.bodies.get(self.selected) if self.selected else None
        if body is None or not body.spec.dentable:
            return None
        if self._map_view is None:
            self._map_view = MapView(self.gl)
        return self._map_view.update(body.maps, self.options.legend_depth), body.maps.normal

    # -- recording -----------------------------------------------------------------------------
    def toggle_recording(self, path: Path | None = None) -> bool:
        """F6 / panel: start recording the window to an MP4 (`path`, or the next free
        dentdemo_NNN.mp4) at the scene's frame rate, the simulation stepping one fixed dt per
        frame meanwhile, so the video plays in real time; or stop and finish it. Returns whether
        it records now; the outcome becomes `message`."""
        if self.recorder is not None:
            self._stop_recording()
            return False
        target = path or _next_free("dentdemo_{:03d}.mp4")
        fps = 1.0 / self.sim.scene.physics.dt
        try:
            self.recorder = VideoFile(self.renderer.size, target, fps, "recording")
        except DentdemoError as exc:
            self._report_error(exc)
            return False
        self.message = f"recording {target} at {fps:g} fps (F6 stops)"
        return True

    def record_frame(self, pixels: np.ndarray) -> None:
        """One frame of the recording (RGB8 rows top-down, the renderer's size); a failing
        writer ends the recording with its one line."""
        if self.recorder is None:
            return
        try:
            self.recorder.add(pixels)
        except DentdemoError as exc:
            recorder, self.recorder = self.recorder, None
            recorder.discard()
            self._report_error(exc)

    def _stop_recording(self) -> None:
        recorder, self.recorder = self.recorder, None
        if recorder is None:
            return
        try:
            recorder.finish()
        except DentdemoError as exc:  # no frames, or a full disk: nothing replaced
            self._report_error(exc)
            return
        seconds = recorder.frames / recorder.fps
        self.message = f"wrote {recorder.out} ({recorder.frames} frames, {seconds:.2f} s)"

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
        # The address-map view shows pass 2, which convex targets otherwise leave out.
        self.sim.draw_every_address(self.options.address_map)
        frame = describe(self.sim, self.scenery, self.camera, self.options)
        return self.renderer.render(frame, target)

    def set_quality(self, name: str) -> None:
        """Switch the render quality preset (panel "quality"); the scene is left as it is."""
        if name != self.quality.name:
            self.quality = preset(name, self.gl.software)
            self._rebuild_renderer(self.renderer.size)

    def resize(self, size: tuple[int, int]) -> None:
        if size != self.renderer.size and min(size) > 0:
            self._stop_recording()  # a video keeps one size: what was recorded is kept
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
        self._stop_recording()
        if self._map_view is not None:
            self._map_view.release()
        self.scenery.release()
        self.renderer.release()
        self.sim.close()


def _next_free(pattern: str) -> Path:
    """The first of pattern.format(1), pattern.format(2), ... that does not exist yet."""
    index = 1
    while Path(pattern.format(index)).exists():
        index += 1
    return Path(pattern.format(index))
