"""The interactive demo: a glfw window with an imgui-bundle panel over a DemoController.

Mouse: left drag orbits, a left click drops a ball above the clicked point (Ctrl + click selects
the body there for the developer tools), right drag throws a ball along the view ray (longer
drags throw harder), middle drag or shift+left drag pans, the wheel zooms. The keys are the
controllers' (`DemoController.keys`: Space pause, N step, R reset, E the material editor, D the
developer tools, ...) and the window's own: P screenshot, Esc quit. The window opens with the
main panel only; the editor and the tools open from their keys and the panel's buttons.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import moderngl

from dentdemo.app import inputs
from dentdemo.app.controller import DemoController
from dentdemo.app.dev_panel import dev_window
from dentdemo.app.editor_panel import editor_window
from dentdemo.app.export import export_gltf
from dentdemo.app.loop import FrameLoop
from dentdemo.errors import DentdemoError
from dentdemo.extras import require_app
from dentdemo.gl.context import GLContext, create_window
from dentdemo.gl.library import flush
from dentdemo.model.materials import MaterialLibrary
from dentdemo.model.scene import Scene
from dentdemo.render.quality import PRESETS

CLICK_PIXELS = 4  # a press that moves less than this is a click, not a drag
#: The window's own keys (the controllers' are DemoController.keys()): screenshot, quit.
WINDOW_KEYS = ("p", "escape")
#: The largest framebuffer-to-window scale taken from the platform (HiDPI screens are 1 to 3):
#: glfw's backend reads the window's size and then the framebuffer's, and a resize landing
#: between the two (a 40 px wide window, then an 8000 px wide framebuffer) gave 200, at which
#: imgui bakes its font 200 times over and runs out of font texture (an assert in new_frame).
MAX_FRAMEBUFFER_SCALE = 4.0


def _sane_scale(io: Any) -> None:
    """Clamp imgui's framebuffer scale (set by glfw's backend this frame) to (0, MAX]; a
    non-finite or non-positive one is 1."""

    def sane(value: float) -> float:
        if not math.isfinite(value) or value <= 0.0:
            return 1.0
        return min(value, MAX_FRAMEBUFFER_SCALE)

    scale = io.display_framebuffer_scale
    io.display_framebuffer_scale = (sane(scale.x), sane(scale.y))


class DemoWindow:
    def __init__(
        self,
        scene: Scene,
        materials: MaterialLibrary,
        size: tuple[int, int] = (1280, 720),
        quality: str | None = None,
    ) -> None:
        require_app("the interactive demo", "glfw", "imgui_bundle")
        import glfw
        from imgui_bundle import imgui  # before glfw: pyGLFW must use imgui-bundle's libglfw

        self.glfw = glfw
        self.imgui = imgui
        self.gl: GLContext = create_window(*size, "dentdemo")
        self.window = self.gl.window
        fb = glfw.get_framebuffer_size(self.window)
        self.app = DemoController(
            self.gl, scene, materials, (max(fb[0], 16), max(fb[1], 16)), quality=quality
        )
        self._press: dict[int, tuple[float, float, int]] = {}  # button -> (x, y, modifiers)
        #: glfw's key code -> the key's name, for every key of the controllers and the window.
        self._key_names = {
            getattr(glfw, f"KEY_{name.rpartition('+')[2].upper()}"): name.rpartition("+")[2]
            for name in [*self.app.keys(), *WINDOW_KEYS]
        }
        self._last_cursor = (0.0, 0.0)
        self._shots = 0
        self._screenshot_at_end: Path | None = None
        self._finished = False  # the last frame of an --exit-after run was presented
        #: The panel's (left, top, width, height) in window pixels, as last drawn.
        self._panel_rect: tuple[float, float, float, float] | None = None
        self._presented = self._title_at = time.perf_counter()
        self._fps = self._frame_ms = 0.0
        glfw.set_mouse_button_callback(self.window, self._on_button)
        glfw.set_cursor_pos_callback(self.window, self._on_cursor)
        glfw.set_scroll_callback(self.window, self._on_scroll)
        glfw.set_key_callback(self.window, self._on_key)
        imgui.create_context()
        imgui.get_io().set_ini_filename("")
        window_address = _address(self.window)
        imgui.backends.glfw_init_for_opengl(window_address, True)
        imgui.backends.opengl3_init("#version 330 core")

    # -- input ---------------------------------------------------------------------------------
    def _ui_wants_mouse(self) -> bool:
        """The panel takes the mouse: imgui says so (from the last frame), or the cursor is on
        the panel's rectangle (a click can land there before imgui has seen the cursor move)."""
        x, y = self.glfw.get_cursor_pos(self.window)
        wants = bool(self.imgui.get_io().want_capture_mouse)
        return wants or inputs.on_panel(self._panel_rect, x, y)

    def _ndc(self, x: float, y: float) -> tuple[float, float]:
        w, h = self.glfw.get_window_size(self.window)
        return x / max(w, 1) * 2 - 1, 1 - y / max(h, 1) * 2

    def _on_button(self, window, button, action, mods) -> None:
        glfw = self.glfw
        x, y = glfw.get_cursor_pos(window)
        if action == glfw.PRESS:
            if not self._ui_wants_mouse():
                self._press[button] = (x, y, mods)
            return
        start = self._press.pop(button, None)
        if start is None:
            return
        moved = abs(x - start[0]) + abs(y - start[1])
        click = button == glfw.MOUSE_BUTTON_LEFT and moved < CLICK_PIXELS
        tools = self.app.tools
        if click and start[2] & glfw.MOD_CONTROL:
            tools.select_at(*self._ndc(x, y))
        elif click and not start[2] & glfw.MOD_SHIFT:
            tools.drop_ball(*self._ndc(x, y))
        elif button == glfw.MOUSE_BUTTON_RIGHT:
            h = glfw.get_window_size(window)[1]
            tools.throw_ball(*self._ndc(x, y), strength=0.5 + moved / max(h, 1) * 2)

    def _on_cursor(self, window, x, y) -> None:
        glfw = self.glfw
        dx, dy = x - self._last_cursor[0], y - self._last_cursor[1]
        self._last_cursor = (x, y)
        left = self._press.get(glfw.MOUSE_BUTTON_LEFT)
        if self._press.get(glfw.MOUSE_BUTTON_MIDDLE) or (left and left[2] & glfw.MOD_SHIFT):
            self.app.view.pan(dx, dy)
        elif left:
            self.app.view.orbit(dx, dy)

    def _on_scroll(self, window, dx, dy) -> None:
        if not self._ui_wants_mouse():
            self.app.view.zoom(dy)

    def _on_key(self, window, key, scancode, action, mods) -> None:
        glfw = self.glfw
        if action != glfw.PRESS or self.imgui.get_io().want_capture_keyboard:
            return
        name = self._key_names.get(key)
        if name is None:
            return
        if mods & glfw.MOD_CONTROL and f"ctrl+{name}" in self.app.keys():
            name = f"ctrl+{name}"
        if name == "p":
            self._screenshot_key()
        elif name == "escape":
            glfw.set_window_should_close(window, True)
        else:
            self.app.press(name)

    def _screenshot_key(self) -> None:
        self._shots += 1
        path = Path(f"dentdemo_{self._shots:03d}.png")
        try:
            self.screenshot(path)
        except DentdemoError as exc:  # a folder that cannot be written: a panel line
            self.app.status.say(str(exc).splitlines()[0])
            return
        self.app.status.say(f"wrote {path}")

    # -- panel ---------------------------------------------------------------------------------
    def _panel(self, fps: float, frame_ms: float) -> None:
        imgui = self.imgui
        app, p = self.app, self.app.panel
        imgui.set_next_window_pos((10, 10), imgui.Cond_.first_use_ever)
        # Wide enough for every label beside its control, units included.
        imgui.set_next_window_size((440, 0), imgui.Cond_.first_use_ever)
        imgui.begin("dentdemo")
        pos, size = imgui.get_window_pos(), imgui.get_window_size()
        self._panel_rect = (pos.x, pos.y, size.x, size.y)
        imgui.push_item_width(200)  # controls on the left half, labels readable on the right
        names = app.sim.materials.names()
        _, index = imgui.combo("ball material", names.index(p.ball_material), names)
        p.ball_material = names[index]
        # Drags, not sliders: no grab handle over the value (drag sideways, or double-click
        # to type).
        changed, radius = imgui.drag_float(
            "ball radius (m)", p.ball_radius, 0.0005, 0.01, 0.15, "%.3f m"
        )
        if changed:  # a typed value may lie beyond the drag's range: clamped, NaN refused
            app.set_panel("ball_radius", radius)
        changed, speed = imgui.drag_float(
            "throw speed (m/s)", p.throw_speed, 0.05, 0.5, 25.0, "%.1f m/s"
        )
        if changed:
            app.set_panel("throw_speed", speed)
        _, index = imgui.combo("new plate material", names.index(p.plate_material), names)
        p.plate_material = names[index]
        if imgui.button("add plate at target"):
            app.tools.add_plate()
        imgui.same_line()
        if imgui.button("reset to the new scene (R)" if app.reload.scene_changed else "reset (R)"):
            app.reset()
        changed, scale = imgui.drag_float(
            "time scale (set)", app.sim.time_scale, 0.01, 0.0, 2.0, "%.2f x real time"
        )
        if changed:
            app.set_time_scale(scale)
        imgui.text(app.rate.text(app.sim.time_scale, app.paused))
        if imgui.button("resume" if app.paused else "pause"):
            app.toggle_pause()
        imgui.same_line()
        if imgui.button("step"):
            app.single_step()
        if imgui.button("close-up on last dent (F)"):
            app.view.close_up()
        imgui.text(app.view.last_dent_text())
        if imgui.button("undo (Ctrl+Z)"):
            app.undo.undo()
        repair = app.undo.repair_target()
        if repair is not None:
            imgui.same_line()
            if imgui.button(f"repair {repair}"):
                app.undo.repair(repair)
        if imgui.button("save state (F5)"):
            app.state.save()
        imgui.same_line()
        if imgui.button("load state (F9)"):
            app.state.load()
        imgui.same_line()
        if imgui.button("export glTF (G)"):
            app.export.gltf()
        if app.message:
            imgui.text_wrapped(app.message)
        imgui.separator()
        view = app.view
        _, view.options.view = imgui.combo(
            "view", view.options.view, ["shaded", "height map", "normal map"]
        )
        presets = list(PRESETS)
        changed, index = imgui.combo("quality", presets.index(view.quality.name), presets)
        if changed:
            view.set_quality(presets[index])
        for name in ("parallax", "wireframe", "contacts", "address_map", "shadows"):
            changed, _ = imgui.checkbox(name.replace("_", " "), getattr(view.options, name))
            if changed:
                view.toggle(name)
        changed, denting = imgui.checkbox("denting", app.sim.denting)
        if changed:
            app.sim.denting = denting
        imgui.separator()
        s = app.sim.stats
        imgui.text(f"fps {fps:.1f}   frame {frame_ms:.2f} ms   quality {view.quality.name}")
        imgui.text(f"physics {s.physics_ms:.2f} ms   carve {s.carve_ms_per_hit:.2f} ms/hit")
        imgui.text(f"hits {s.hits}   impacts {s.impacts}   queued {len(app.sim.queue)}")
        imgui.text(f"bodies {len(app.sim.bodies)}   t = {app.sim.world.time:.2f} s")
        imgui.separator()
        if imgui.button(
            "close the material editor (E)" if app.editor.visible else "material editor (E)"
        ):
            app.editor.toggle()
        imgui.same_line()
        if imgui.button(
            "close the developer tools (D)" if app.tools.visible else "developer tools (D)"
        ):
            app.tools.toggle()
        imgui.pop_item_width()
        imgui.end()
        if app.editor.visible:
            editor_window(imgui, app)
        if app.tools.visible:
            dev_window(imgui, app)

    # -- loop ----------------------------------------------------------------------------------
    def screenshot(self, path: Path) -> Path:
        """The window's image (scene and panel) as a PNG."""
        from dentdemo.outputs import write_png

        ctx = self.gl.ctx
        w, h = self.glfw.get_framebuffer_size(self.window)
        pixels = self.gl.read_framebuffer(ctx.screen, 3)[::-1]
        write_png(path, pixels[:h, :w])
        return path

    def run(
        self,
        screenshot: Path | None = None,
        exit_after: float | None = None,
        gltf: Path | None = None,
    ) -> int:
        """The frame loop with this window as its backend. With exit_after, the simulation runs
        at its fixed dt per frame (so the image is deterministic), the window's image is saved
        after that many simulated seconds, every body is written to `gltf` if given, and the
        window closes. A window closed before (Esc) while a screenshot or glTF was due is an
        error naming what was not written."""
        self._screenshot_at_end = screenshot
        loop = FrameLoop(self.app, self, fixed_dt=exit_after is not None)
        try:
            loop.run(until_time=exit_after)
            early = exit_after is not None and not self._finished
            if gltf is not None and not early:
                export_gltf(self.app.sim, gltf)
            stopped_at = self.app.sim.world.time
        finally:
            self.close()
        due = (("--screenshot", screenshot), ("--gltf", gltf))
        missed = [f"{flag} {path}" for flag, path in due if path is not None]
        if early and missed:
            raise DentdemoError(
                f"{missed[0].split()[0]}: the window was closed at t = {stopped_at:.2f} s, "
                f"before --exit-after {exit_after:g} s; not written: {', '.join(missed)}"
            )
        return 0

    # -- the loop's backend --------------------------------------------------------------------
    def open(self) -> bool:
        self.glfw.poll_events()
        return not self.glfw.window_should_close(self.window)

    def size(self) -> tuple[int, int]:
        w, h = self.glfw.get_framebuffer_size(self.window)
        return (int(w), int(h))

    def target(self) -> moderngl.Framebuffer:
        """The renderer draws straight into the window (no copy of the frame)."""
        return self.gl.ctx.screen

    def present(self, app: DemoController, output: moderngl.Framebuffer, last: bool) -> None:
        """The panel over the scene the renderer drew into the screen; swapped (or saved, on
        the last frame of an --exit-after run)."""
        glfw, imgui, ctx = self.glfw, self.imgui, self.gl.ctx
        now = time.perf_counter()
        wall, self._presented = now - self._presented, now
        if app.recording.recorder is not None:  # the scene, without the panel
            w, h = self.size()
            app.recording.record_frame(self.gl.read_framebuffer(ctx.screen, 3)[::-1][:h, :w])
        flush()  # the rasteriser finishes the frame while the panel is built
        imgui.backends.opengl3_new_frame()
        imgui.backends.glfw_new_frame()
        _sane_scale(imgui.get_io())
        imgui.new_frame()
        self._panel(self._fps, self._frame_ms)
        imgui.render()
        ctx.screen.use()
        imgui.backends.opengl3_render_draw_data(imgui.get_draw_data())
        self._frame_ms = (time.perf_counter() - now) * 1e3
        rate = 1.0 / max(wall, 1e-6)
        self._fps = 0.9 * self._fps + 0.1 * rate if self._fps else rate
        if now - self._title_at > 0.5:
            glfw.set_window_title(self.window, f"dentdemo | {app.stats_line(self._fps)}")
            self._title_at = now
        self._finished = self._finished or last
        if last and self._screenshot_at_end is not None:
            self.screenshot(self._screenshot_at_end)
            return
        glfw.swap_buffers(self.window)

    def close(self) -> None:
        self.imgui.backends.opengl3_shutdown()
        self.imgui.backends.glfw_shutdown()
        self.imgui.destroy_context()
        self.app.close()
        self.gl.release()
        self.glfw.terminate()


def _address(window) -> int:
    import ctypes

    return ctypes.cast(window, ctypes.c_void_p).value or 0
