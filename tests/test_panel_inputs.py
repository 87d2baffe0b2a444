"""The demo panel under abuse: typed values are clamped to the scene files' bounds (README, "Scene
files": sizes 0.001 m to 100 m, speeds up to 1000 m/s), NaN is refused, and a click on the panel
never reaches the scene. Driven through the controller (no window), and one real window under
Xvfb for the click."""

from __future__ import annotations

import math
import os

import pytest

from cli_helpers import python_json
from dentdemo.app import inputs
from dentdemo.app.controller import PanelState
from dentdemo.resources import assets_dir

BALL_DROP = assets_dir() / "scenes" / "ball_drop.toml"
#: README's scene-file table: radius, side ... 0.001 m to 100 m; velocity up to 1000 m/s.
SIZE_MIN, SIZE_MAX, SPEED_MAX = 0.001, 100.0, 1000.0


@pytest.fixture
def app(ball_drop_app):
    return ball_drop_app


@pytest.mark.parametrize(
    "name,typed,kept",
    [
        ("ball_radius", 0.0, SIZE_MIN),
        ("ball_radius", -3.0, SIZE_MIN),
        ("ball_radius", 1000.0, SIZE_MAX),
        ("ball_radius", math.inf, SIZE_MAX),
        ("ball_radius", 0.07, 0.07),
        ("throw_speed", -1.0, 0.0),
        ("throw_speed", 1e9, SPEED_MAX),
        ("plate_side", 0.0, SIZE_MIN),
        ("plate_side", 500.0, SIZE_MAX),
    ],
)
def test_typed_values_are_clamped_to_the_scene_bounds(app, name, typed, kept):
    assert app.set_panel(name, typed) == kept
    assert getattr(app.panel, name) == kept


@pytest.mark.parametrize("name", ["ball_radius", "throw_speed", "plate_side"])
def test_nan_is_refused_and_the_value_kept(app, name):
    before = getattr(app.panel, name)
    assert app.set_panel(name, math.nan) == before
    assert getattr(app.panel, name) == before


def test_a_click_after_radius_zero_drops_a_one_millimetre_ball(app):
    """The panel field set to 0 (typed, or set by code around the setter): the click drops the
    smallest ball a scene file allows instead of ending the demo."""
    app.panel.ball_radius = 0.0
    body_id = app.tools.drop_ball(0.0, -0.5)
    assert body_id is not None
    assert app.sim.bodies[body_id].spec.shape.radius == SIZE_MIN
    app.panel.ball_radius = math.nan  # NaN set around the setter: the default radius
    body_id = app.tools.throw_ball(0.0, 0.0)
    assert app.sim.bodies[body_id].spec.shape.radius == PanelState().ball_radius


def test_time_scale_nan_is_refused_and_the_demo_keeps_stepping(app):
    """1/30 s of wall time at scale 1 is two 1/60 s steps (ball_drop.toml's dt)."""
    app.set_time_scale(math.nan)
    assert app.sim.time_scale == 1.0
    assert app.update(1.0 / 30.0) == 2
    app.set_time_scale(math.inf)
    assert app.sim.time_scale == inputs.TIME_SCALE[1]
    app.set_time_scale(-2.0)
    assert app.sim.time_scale == 0.0 and app.update(1.0) == 0
    app.set_time_scale(1.0)
    assert app.update(1.0 / 30.0) == 2


@pytest.mark.slow
def test_time_scale_set_around_the_setter_is_recovered_by_reset(app):
    """A NaN time debt (the scale set to NaN on the Simulation itself) is cleared by R."""
    app.sim.time_scale = math.nan
    app.update(1.0 / 30.0)
    app.sim.time_scale = 1.0
    app.reset()
    assert app.update(1.0 / 30.0) == 2


def test_on_panel_is_the_rectangle_inclusive():
    rect = (10.0, 10.0, 440.0, 300.0)
    assert inputs.on_panel(rect, 10.0, 10.0) and inputs.on_panel(rect, 450.0, 310.0)
    assert not inputs.on_panel(rect, 9.9, 50.0) and not inputs.on_panel(rect, 100.0, 310.1)
    assert not inputs.on_panel(None, 100.0, 100.0)


_CLICKS = """
import json, sys
import glfw
from dentdemo.app.loop import FrameLoop
from dentdemo.app.window import DemoWindow
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
lib = load_materials()
window = DemoWindow(load_scene(sys.argv[1], lib), lib, (640, 360), "low")
loop = FrameLoop(window.app, window, fixed_dt=True)
window.app.paused = True
def click(x, y):
    glfw.set_cursor_pos(window.window, x, y)
    before = len(window.app.sim.bodies)
    window._on_button(window.window, glfw.MOUSE_BUTTON_LEFT, glfw.PRESS, 0)
    window._on_button(window.window, glfw.MOUSE_BUTTON_LEFT, glfw.RELEASE, 0)
    return len(window.app.sim.bodies) - before
glfw.set_cursor_pos(window.window, 600, 300)
loop.frame()  # imgui sees the cursor over the scene
# The panel is placed at (10, 10), 440 px wide (window.py): (100, 40) lies on it.
on_panel = click(100, 40)
loop.frame()
on_scene = click(600, 300)
window.close()
print(json.dumps({"on_panel": on_panel, "on_scene": on_scene}))
"""


@pytest.mark.slow
def test_a_click_on_the_panel_drops_no_ball(xvfb):
    """A click on the panel, before imgui has drawn a frame with the cursor there, drops nothing;
    the same click on the floor drops one ball."""
    env = {**os.environ, "DISPLAY": xvfb}
    clicks = python_json(_CLICKS, BALL_DROP, env=env, timeout=120)
    assert clicks == {"on_panel": 0, "on_scene": 1}
