"""Rolling resistance (issue 21, item 5): the `rolling_friction` key (C_rr) becomes ODE's rolling
contact rows, so a ball rolling on a plate comes to rest where a hand computation says.

By hand, a solid ball (mass m, radius R, I = 2/5 m R^2) rolling without slipping on a level
plate: the contact resists the rolling with a torque rho N, rho = C_rr R, N = m g. About the
centre, I alpha = F R - rho N; along the plate, m a = -F; rolling, a = alpha R. So
(m + I / R^2) a = -rho N / R, a = -(5/7) C_rr g, and the ball stops after
d = v^2 / (2 * g * C_rr * 5/7) = 7 v^2 / (10 g C_rr)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dentdemo.errors import ConfigError
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
from dentdemo.physics.simulate import build_world
from scene_text import GRAVITY, ball, plate, steel_like

MATERIALS = steel_like("roller", 0.01, "rolling_friction = {crr}\n")

SCENE = "\n".join(
    [GRAVITY, plate("roller", side=4.0), ball("roller", "[0.0, {y}, 0.0]", radius="{radius}")]
)

G = 9.81
RADIUS = 0.04  # m
SPEED = 0.5  # m/s


def _roll(tmp_path, crr: float, heading_deg: float, seconds: float) -> tuple[float, float]:
    """A ball set rolling (no slip) at SPEED along `heading_deg` (about +y, from +x) on a level
    plate of C_rr `crr`: (distance covered when it stopped or time ran out, m; speed then)."""
    materials = tmp_path / "m.toml"
    materials.write_text(MATERIALS.format(crr=crr))
    scene_path = tmp_path / "s.toml"
    scene_path.write_text(SCENE.format(radius=RADIUS, y=0.02 + RADIUS))
    lib = load_materials([materials])
    world = build_world(load_scene(scene_path, lib))
    try:
        h = math.radians(heading_deg)
        direction = np.array([math.cos(h), 0.0, -math.sin(h)])
        # Rolling without slip: the contact point at rest, omega = (up x v) / R... here
        # omega = v x (-up) / R = (d x -y) * v / R.
        spin = np.cross(direction, [0.0, -1.0, 0.0]) * SPEED / RADIUS
        for _ in range(10):  # settle onto the plate first
            world.step()
        world.set_velocity("ball", direction * SPEED, spin)
        start = world.pose("ball")[0].copy()
        steps = round(seconds / world.spec.dt)
        for _ in range(steps):
            world.step()
            if np.linalg.norm(world.velocity("ball")[0]) < 1e-4:
                break
        end = world.pose("ball")[0]
        return float(np.linalg.norm((end - start)[[0, 2]])), float(
            np.linalg.norm(world.velocity("ball")[0])
        )
    finally:
        world.close()


@pytest.mark.parametrize("heading", [0.0, 45.0, 120.0])
def test_a_rolling_ball_stops_where_the_hand_computation_says(tmp_path, heading):
    """Along ODE's contact axes (0 degrees) and across them: the same distance, since each
    contact's frame is turned to the axis it rolls about."""
    crr = 0.05
    expected = 7 * SPEED**2 / (10 * G * crr)  # 0.3568 m, in 1.43 s
    distance, speed = _roll(tmp_path, crr, heading, seconds=3.0)
    assert speed < 1e-4
    assert distance == pytest.approx(expected, rel=0.01)  # 0.3563 m measured


def test_without_rolling_friction_it_rolls_on(tmp_path):
    distance, speed = _roll(tmp_path, 0.0, 45.0, seconds=1.43)
    assert speed > 0.98 * SPEED
    assert distance > 0.98 * SPEED * 1.43


def test_rolling_friction_is_validated_like_every_key(tmp_toml):
    for value, message in (("-0.1", "must be >= 0"), ("2", "must be <= 1"), ('"x"', "number")):
        path = tmp_toml(MATERIALS.replace("{crr}", value))
        with pytest.raises(ConfigError) as caught:
            load_materials([path])
        text = str(caught.value)  # the bound, then the key table's range and its reason
        assert text.startswith(f"{path}: [materials.roller] key 'rolling_friction' = ")
        assert message in text and "\n" not in text


def test_every_shipped_preset_sets_a_rolling_coefficient():
    lib = load_materials()
    for name, material in lib.materials.items():
        assert 0.0 < material.rolling_friction <= 0.1, name
