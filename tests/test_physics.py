"""Physics against its oracles: bounce heights, eq. 2 for hand-computed collisions, resting bodies,
determinism, and bad input."""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

from cli_helpers import dentdemo
from dentdemo.errors import ConfigError
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import BodySpec, PhysicsSpec, load_scene
from dentdemo.model.shapes import Box, Capsule, Plane, Plate, Sphere
from dentdemo.physics.world import PhysicsWorld

ROOT = Path(__file__).resolve().parents[1]
BALL_DROP = ROOT / "assets" / "scenes" / "ball_drop.toml"
LIB = load_materials()
G = 9.81


def _material(name: str, **changes):
    return dataclasses.replace(LIB.get(name), **changes)


def _drop(eps: float, height: float, dt: float, substeps: int = 4) -> tuple[float, float]:
    """Drop a ball from `height` (its lowest point) on the ground: (rebound peak, impact speed)."""
    mat = _material("steel", restitution=eps)
    world = PhysicsWorld(PhysicsSpec(dt=dt, substeps=substeps))
    world.add_body(BodySpec("ground", Plane(), mat, static=True))
    world.add_body(BodySpec("ball", Sphere(0.05), mat, position=(0, height + 0.05, 0)))
    impacts, peak, rising = [], 0.0, False
    for _ in range(int(4.0 / dt)):
        impacts += world.step()
        vy = world.velocity("ball")[0][1]
        if impacts and vy > 0:
            rising = True
        if rising:
            peak = max(peak, world.pose("ball")[0][1] - 0.05)
            if vy < 0:
                break
    world.close()
    return peak, impacts[0].approach_speed


@pytest.mark.parametrize("eps", [0.2, 0.5, 0.8])
@pytest.mark.parametrize("dt,substeps", [(1 / 240, 4), (1 / 960, 4)])
def test_bounce_height_is_eps_squared(eps, dt, substeps):
    h = 1.0
    peak, speed = _drop(eps, h, dt, substeps)
    # The contact is found up to one substep late (the ball has sunk up to v*dt_sub), the bounce is
    # applied within a substep in which gravity still acts, and the rebound starts from the sunk
    # position: each costs at most one substep of travel at impact speed.
    tolerance = 3 * speed * dt / substeps
    assert abs(peak - eps**2 * h) <= tolerance
    assert speed == pytest.approx(math.sqrt(2 * G * h), abs=G * dt)


def test_eq2_head_on_two_dynamic_spheres():
    steel, alu = LIB.get("steel"), LIB.get("aluminium")
    world = PhysicsWorld(PhysicsSpec(gravity=(0, 0, 0), dt=1 / 240, substeps=4))
    world.add_body(BodySpec("a", Sphere(0.05), steel, position=(0, 1, 0), velocity=(1, 0, 0)))
    world.add_body(BodySpec("b", Sphere(0.05), alu, position=(0.3, 1, 0), velocity=(-2, 0, 0)))
    m_a = steel.density * 4 / 3 * math.pi * 0.05**3
    m_b = alu.density * 4 / 3 * math.pi * 0.05**3
    impacts = []
    for _ in range(60):
        impacts += world.step()
    assert len(impacts) == 1
    hit = impacts[0]
    # By hand: closing speed 3 m/s, eps = min(0.6, 0.5) = 0.5.
    j_hand = (1 + 0.5) * 3.0 / (1 / m_a + 1 / m_b)
    assert hit.j == pytest.approx(j_hand, rel=1e-6)
    assert hit.j_elastic == pytest.approx(2.0 * 3.0 / (1 / m_a + 1 / m_b), rel=1e-6)
    assert hit.mass_a + hit.mass_b == pytest.approx(m_a + m_b, rel=1e-9)
    assert abs(hit.normal[0]) == pytest.approx(1.0, abs=1e-9)
    # Afterwards: momentum conserved; closing speed reversed and scaled by eps.
    va, vb = world.velocity("a")[0][0], world.velocity("b")[0][0]
    assert m_a * va + m_b * vb == pytest.approx(m_a * 1 - m_b * 2, abs=1e-6)
    assert vb - va == pytest.approx(0.5 * 3.0, rel=0.03)
    world.close()


def test_eq2_sphere_on_static_plate():
    lead = LIB.get("lead")
    steel = LIB.get("steel")
    world = PhysicsWorld(PhysicsSpec(dt=1 / 240, substeps=4))
    world.add_body(
        BodySpec(
            "plate",
            Plate(0.5, 0.02),
            lead,
            position=(0, 0.02, 0),
            static=True,
        )
    )
    world.add_body(BodySpec("ball", Sphere(0.04), steel, position=(0, 0.02 + 0.04 + 0.8, 0)))
    impacts = []
    for _ in range(120):
        impacts += world.step()
    hit = impacts[0]
    assert {hit.body_a, hit.body_b} == {"plate", "ball"}
    assert hit.body_a == "plate" and hit.normal[1] == pytest.approx(1.0)  # from plate towards ball
    m = steel.density * 4 / 3 * math.pi * 0.04**3
    assert math.isinf(hit.mass_a) and hit.mass_b == pytest.approx(m, rel=1e-9)
    v = hit.approach_speed
    assert v == pytest.approx(math.sqrt(2 * G * 0.8), abs=G / 240)
    assert hit.j == pytest.approx((1 + min(lead.restitution, steel.restitution)) * v * m, rel=1e-9)
    assert hit.j_elastic == pytest.approx(2 * v * m, rel=1e-9)
    # The reported pose is the ball's at that moment: touching or just inside the plate.
    assert hit.pose_b[0][1] - 0.04 - 0.02 == pytest.approx(-hit.depth, abs=v / 240 + 1e-3)
    world.close()


def test_resting_ball_produces_no_impacts():
    steel = LIB.get("steel")
    world = PhysicsWorld(PhysicsSpec())
    world.add_body(BodySpec("ground", Plane(), steel, static=True))
    world.add_body(BodySpec("ball", Sphere(0.05), steel, position=(0, 0.051, 0)))
    for _ in range(60):
        world.step()
    later = []
    for _ in range(600):
        later += world.step()
    assert later == []
    assert world.pose("ball")[0][1] == pytest.approx(0.05, abs=2e-3)
    world.close()


def _ball_drop_world():
    from dentdemo.physics.simulate import build_world

    return build_world(load_scene(BALL_DROP, LIB))


@pytest.mark.slow
def test_ball_drop_is_deterministic_and_settles():
    runs = []
    for _ in range(2):
        world = _ball_drop_world()
        log = [json.dumps(i.as_dict(), sort_keys=True) for _ in range(300) for i in world.step()]
        runs.append((log, {b: world.pose(b)[0].tolist() for b in world.bodies}))
        world.close()
    assert runs[0] == runs[1]
    assert len(runs[0][0]) >= 10
    # Nothing fell through the ground or a plate.
    assert all(p[1] > -1e-3 for p in runs[0][1].values())


def test_non_finite_body_is_removed_with_a_warning():
    steel = LIB.get("steel")
    world = PhysicsWorld(PhysicsSpec(gravity=(0, 0, 0)))
    world.add_body(BodySpec("ok", Sphere(0.05), steel, position=(0, 1, 0)))
    world.add_body(BodySpec("bad", Sphere(0.05), steel, position=(2, 1, 0)))
    world.set_velocity("bad", np.array([math.inf, 0.0, 0.0]))
    with pytest.warns(RuntimeWarning, match="'bad' became non-finite"):
        world.step()
    assert "bad" not in world.bodies and world.removed == ["bad"]
    world.step()
    assert np.isfinite(world.pose("ok")[0]).all()
    world.close()


def test_bodies_can_be_added_and_removed_while_running():
    steel = LIB.get("steel")
    world = PhysicsWorld(PhysicsSpec())
    world.add_body(BodySpec("ground", Plane(), steel, static=True))
    for i in range(5):
        world.add_body(
            BodySpec(
                f"b{i}",
                Capsule(0.03, 0.1),
                steel,
                position=(i * 0.2, 0.5, 0),
            )
        )
        world.step()
    world.remove_body("b2")
    for _ in range(120):
        world.step()
    assert set(world.bodies) == {"ground", "b0", "b1", "b3", "b4"}
    with pytest.raises(ValueError, match="duplicate"):
        world.add_body(BodySpec("b0", Sphere(0.1), steel))
    world.close()


SCENE_OK = """
[[body]]
id = "ground"
shape = "plane"
material = "oak"

[[body]]
id = "ball"
shape = "sphere"
radius = 0.05
material = "steel"
position = [0, 1, 0]
"""


@pytest.mark.parametrize(
    "text,expected",
    [
        (
            SCENE_OK.replace("radius = 0.05", "radius = 0"),
            "[body.ball] key 'radius' = 0: must be >= 0.001",
        ),
        (SCENE_OK.replace("radius = 0.05", "radius = nan"), "key 'radius' = nan: must be finite"),
        (SCENE_OK.replace("radius = 0.05", "radius = -1"), "must be >= 0.001"),
        (
            SCENE_OK.replace('shape = "sphere"', 'shape = "torus"'),
            "key 'shape' = 'torus': must be one of",
        ),
        (
            SCENE_OK.replace('material = "steel"', 'material = "adamantium"'),
            "unknown material 'adamantium'",
        ),
        (SCENE_OK.replace('id = "ball"', 'id = "ground"'), "duplicate id"),
        (SCENE_OK.replace("position = [0, 1, 0]", "position = [0, inf, 0]"), "key 'position'"),
        (
            SCENE_OK.replace("position = [0, 1, 0]", "position = [0, 1]"),
            "must be a list of 3 numbers",
        ),
        (SCENE_OK + "colour = 'red'\n", "key 'colour' = 'red': unknown key"),
        (SCENE_OK + "[physics]\ndt = 0\n", "[physics] key 'dt' = 0: must be >= 1e-05"),
        (SCENE_OK + "[camera]\nfov_deg = 500\n", "key 'fov_deg' = 500"),
        ("[bodies]\n", "[bodies]: unknown table"),
        ("[[body]]\nshape = 'sphere'\n", "missing key 'id'"),
        (
            SCENE_OK.replace('shape = "plane"', 'shape = "plane"\nstatic = false'),
            "a plane is always static",
        ),
    ],
)
def test_bad_scenes(tmp_toml, text, expected):
    path = tmp_toml(text, "scene.toml")
    with pytest.raises(ConfigError) as info:
        load_scene(path, LIB)
    assert str(path) in str(info.value)
    assert expected in str(info.value)


def test_ball_drop_scene_has_what_the_demo_needs():
    scene = load_scene(BALL_DROP, LIB)
    plates = {b.material.name for b in scene.bodies if isinstance(b.shape, Plate)}
    assert {"steel", "aluminium", "lead", "oak"} <= plates
    balls = [b for b in scene.bodies if isinstance(b.shape, Sphere)]
    assert len({b.material.name for b in balls}) >= 4
    assert len({b.shape.radius for b in balls}) >= 3 and len({b.position[1] for b in balls}) >= 3
    assert any(isinstance(b.shape, Box) for b in scene.bodies)


def _simulate(*args):
    return dentdemo("simulate", *args)


def _scene_bodies(path: Path) -> dict[str, dict]:
    """Each body's table of a scene file, read with tomllib, with its material's table."""
    materials = tomllib.loads((ROOT / "assets" / "materials.toml").read_text())["materials"]
    bodies = tomllib.loads(path.read_text())["body"]
    return {b["id"]: {**b, "mat": materials[b["material"]]} for b in bodies}


def _hand_mass(body: dict) -> float | None:
    """kg from the files: density times the solid's volume; None for static bodies."""
    if body.get("static") or body["shape"] == "plane":
        return None
    rho = body["mat"]["density_kg_m3"]
    if body["shape"] == "sphere":
        return rho * 4.0 / 3.0 * math.pi * body["radius"] ** 3
    assert body["shape"] == "box", body
    return rho * math.prod(body["size"])


@pytest.mark.slow
def test_simulate_json_matches_eq2_and_repeats_exactly():
    """Every printed impact against eq. 2 written out here from the paper, with masses and
    restitutions read from the scene and materials files, and the first impact (the clay ball
    dropped 0.535 m onto the oak plate) against its fall worked by hand."""
    first = _simulate("--scene", str(BALL_DROP), "--steps", "600", "--json")
    second = _simulate("--scene", str(BALL_DROP), "--steps", "600", "--json")
    assert first.returncode == 0, first.stderr
    assert first.stdout == second.stdout
    lines = [json.loads(line) for line in first.stdout.splitlines()]
    assert len(lines) >= 10
    bodies = _scene_bodies(BALL_DROP)
    for hit in lines:
        a, b = bodies[hit["body_a"]], bodies[hit["body_b"]]
        for key, body in (("a", a), ("b", b)):
            assert hit[f"eps_{key}"] == body["mat"]["restitution"]
            mass = _hand_mass(body)
            assert hit[f"mass_{key}"] == (None if mass is None else pytest.approx(mass, rel=1e-9))
        # j = -(1 + min(eps_A, eps_B)) N . (v_B - v_A) / (1/m_A + 1/m_B), static: 1/m = 0.
        inv = sum(0.0 if hit[k] is None else 1.0 / hit[k] for k in ("mass_a", "mass_b"))
        closing = float(np.dot(hit["normal"], np.subtract(hit["vel_b"], hit["vel_a"])))
        eps = min(a["mat"]["restitution"], b["mat"]["restitution"])
        assert hit["j"] == pytest.approx(-(1 + eps) * closing / inv, rel=1e-9)
        assert hit["j_elastic"] == pytest.approx(-2 * closing / inv, rel=1e-9)
        assert hit["approach_speed"] == pytest.approx(-closing, rel=1e-9) and closing < 0
    hit = lines[0]
    assert (hit["body_a"], hit["body_b"]) == ("oak_plate", "clay_ball")
    clay = bodies["clay_ball"]
    drop = clay["position"][1] - clay["radius"] - 0.02  # onto the plate's top face at y = 0.02
    speed = math.sqrt(2 * G * drop)  # 3.240 m/s after 0.535 m
    mass = 1700 * 4 / 3 * math.pi * 0.045**3  # 0.649 kg
    assert hit["approach_speed"] == pytest.approx(speed, rel=0.01)
    assert hit["j"] == pytest.approx((1 + 0.05) * mass * speed, rel=0.01)  # 2.21 N s
    assert hit["j_elastic"] == pytest.approx(2 * mass * speed, rel=0.01)


def test_simulate_bad_scene_is_one_line(tmp_toml):
    path = tmp_toml(SCENE_OK.replace('material = "steel"', 'material = "adamantium"'), "s.toml")
    result = _simulate("--scene", str(path), "--steps", "10")
    assert result.returncode == 1
    assert len(result.stderr.strip().splitlines()) == 1 and "adamantium" in result.stderr


def test_trimesh_body_collides(tmp_path):
    path = tmp_path / "block.obj"
    trimesh.creation.box(extents=(0.2, 0.2, 0.2)).export(path)
    text = (
        SCENE_OK
        + f'\n[[body]]\nid = "mesh"\nshape = "mesh"\nmesh = "{path}"\n'
        + 'material = "oak"\nposition = [1, 0.5, 0]\n'
    )
    scene_path = tmp_path / "scene.toml"
    scene_path.write_text(text)
    from dentdemo.physics.simulate import build_world

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        world = build_world(load_scene(scene_path, LIB))
    impacts = [i for _ in range(120) for i in world.step() if "mesh" in (i.body_a, i.body_b)]
    assert impacts and impacts[0].j > 0
    assert world.pose("mesh")[0][1] == pytest.approx(0.1, abs=0.01)  # resting on the ground
    world.close()


def test_small_stack_stays_stacked_and_quiet():
    oak = LIB.get("oak")
    world = PhysicsWorld(PhysicsSpec())
    world.add_body(BodySpec("ground", Plane(), oak, static=True))
    for i in range(4):
        world.add_body(
            BodySpec(
                f"box{i}",
                Box((0.2, 0.2, 0.2)),
                oak,
                position=(0.01 * i, 0.1 + 0.2 * i + 0.001, 0),
            )
        )
    late = []
    for step in range(600):  # 10 s
        impacts = world.step()
        if step > 60:
            late += impacts
    assert late == []
    for i in range(4):
        position = world.pose(f"box{i}")[0]
        assert position[1] == pytest.approx(0.1 + 0.2 * i, abs=2e-3)
        assert abs(position[0] - 0.01 * i) < 5e-3
        assert np.linalg.norm(world.velocity(f"box{i}")[0]) < 1e-2
    world.close()


def _without_libode(*args: str) -> subprocess.CompletedProcess:
    """Run the CLI in a process where the ODE library cannot be found."""
    code = (
        "import ctypes.util, sys;"
        "real = ctypes.util.find_library;"
        "ctypes.util.find_library = lambda name: None if name == 'ode' else real(name);"
        "from dentdemo.cli import main; sys.exit(main(sys.argv[1:]))"
    )
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True)


@pytest.mark.slow
def test_missing_ode_library_is_one_clear_line():
    result = _without_libode("simulate", "--scene", str(BALL_DROP), "--steps", "1")
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "libode8" in lines[0] and "ODE library" in lines[0]
    # Commands that need no physics still work.
    assert _without_libode("materials", "--json").returncode == 0


def test_every_ode_function_the_code_calls_is_checked_at_load():
    """Each `ode.dX(` or `loadOde("dX"` in the source must be in REQUIRED_SYMBOLS, so that a
    library without it fails at start with its name instead of mid-run."""
    import re

    from dentdemo.physics import ode as ode_module

    source = "\n".join(p.read_text() for p in (ROOT / "src" / "dentdemo").rglob("*.py"))
    called = set(re.findall(r"\bode\.(d[A-Z]\w+)\(", source))
    called |= set(re.findall(r'loadOde\(\s*"(d[A-Z]\w+)"', source))
    # Types (structures and callback prototypes), not functions.
    called -= {
        *("dMass", "dContact", "dContactGeom", "dReal"),
        *("dTriCallback", "dTriArrayCallback", "dTriRayCallback"),
    }
    assert len(called) > 40
    assert called - set(ode_module.REQUIRED_SYMBOLS) == set()
    assert "ODE_double_precision" in ode_module.ode_configuration()


def test_missing_ode_symbol_is_named(monkeypatch):
    import odepy

    from dentdemo.errors import PhysicsLibraryError
    from dentdemo.physics import ode as ode_module

    monkeypatch.setattr(odepy, "dCollide", None)  # what odepy leaves for a symbol it cannot find
    with pytest.raises(PhysicsLibraryError, match="lacks dCollide"):
        ode_module._load()


def test_ode_messages_are_one_dentdemo_line_and_quiet_silences_them(capsys):
    """ODE's own messages (dMessage, printf-style) arrive as one formatted stderr line."""
    import ctypes

    from odepy.common import loadOde

    from dentdemo import log
    from dentdemo.physics.ode import ode  # noqa: F401 - installs the handlers

    message = loadOde("dMessage", None, ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p)
    log.configure(quiet=False)
    message(7, b"mass %s\nmust be > 0", b"of body x")
    err = capsys.readouterr().err
    assert err == "dentdemo: warning: ODE message 7: mass of body x must be > 0\n"
    log.configure(quiet=True)
    message(7, b"anything %s", b"at all")
    assert capsys.readouterr().err == ""
    log.configure(quiet=False)


def test_a_library_source_warning_is_not_shown(capsys):
    """A dependency whose source has an invalid string escape (pyrr on Python 3.12, imported
    without a compiled .pyc) warns at compile time with neither file nor advice: not our user's
    business. Other warnings still come through as one line."""
    import warnings

    from dentdemo import log

    log.configure(quiet=False)
    compile("x = '\\ '", "library.py", "exec")  # SyntaxWarning (3.12), DeprecationWarning (3.11)
    assert capsys.readouterr().err == ""
    warnings.warn("something the user should know", stacklevel=1)
    assert capsys.readouterr().err == "dentdemo: warning: something the user should know\n"


@pytest.mark.parametrize("turn_deg", [0.0, 40.0])
def test_a_crate_dropped_on_a_crate_dents_by_eq4_and_then_rests_quietly(turn_deg):
    """Two 20 cm oak crates as triangle meshes (a mesh file's geom), the upper one dropped flat
    from 2 cm onto the static lower one, turned about Y (crates.toml turns it 40 degrees). ODE's
    mesh-mesh collider adds phantom edge contacts to faces lying flat on each other (normals in
    the faces' plane, centimetres deep): they spun the crate up and made an impact along a
    sideways normal every few frames, which carved the crates' faces to max_dent_depth in stripes.
    Oracles by hand: one landing impact along +Y at v = sqrt(2 g h), j(eps=1) = 2 m v (the lower
    crate static), eq. 4-5's depth from the preset's moduli; afterwards no impact and no spin."""
    oak = LIB.get("oak")
    box = trimesh.creation.box(extents=(0.2, 0.2, 0.2))
    arrays = (np.asarray(box.vertices, dtype=np.float64), np.asarray(box.faces, dtype=np.int64))
    world = PhysicsWorld(PhysicsSpec(dt=1 / 60, substeps=8))
    lower = BodySpec("lower", _mesh_shape(), oak, position=(0.0, 0.1, 0.0), static=True)
    world.add_body(lower, arrays)
    gap = 0.02
    half = math.radians(turn_deg) / 2
    upper = BodySpec(
        "upper",
        _mesh_shape(),
        oak,
        position=(0.01, 0.3 + gap, 0.0),
        orientation=(math.cos(half), 0.0, math.sin(half), 0.0),
    )
    world.add_body(upper, arrays)
    impacts = [(step, i) for step in range(300) for i in world.step()]
    first = impacts[0][1]
    assert {first.body_a, first.body_b} == {"lower", "upper"}
    assert abs(first.normal[1]) > math.cos(math.radians(2.0))  # the faces' normal, not an edge's
    m = oak.density * 0.2**3  # kg
    v = math.sqrt(2 * G * gap)  # m/s at first touch
    assert first.approach_speed == pytest.approx(v, abs=G / 60)
    assert first.j_elastic == pytest.approx(2 * m * first.approach_speed, rel=1e-6)
    # Eq. 4-5 by hand from the preset: k = k_per_compliance (1/P - 1/E), Y = Y_unit (1/(1-eps) - 1).
    table = tomllib.loads((ROOT / "assets" / "materials.toml").read_text())
    raw, cal = table["materials"]["oak"], table["calibration"]
    k = cal["k_per_compliance"] * (1 / raw["plastic_modulus_Pa"] - 1 / raw["youngs_modulus_Pa"])
    threshold = cal["Y_unit_Ns"] * (1 / (1 - raw["restitution"]) - 1)
    by_hand = min(raw["max_dent_depth_m"], k * (2 * m * v - threshold))
    from dentdemo.model.impulse import dent_depth

    depth = float(dent_depth(first.j_elastic, oak.k, oak.Y, oak.max_dent_depth))
    assert 0.0 < by_hand < raw["max_dent_depth_m"]  # the case tests eq. 4, not the bound
    assert depth == pytest.approx(by_hand, rel=0.05)
    # Every impact is the landing or a bounce of it (restitution 0.4), slower, along the faces'
    # normal; after a second, none.
    assert all(abs(i.normal[1]) > math.cos(math.radians(2.0)) for _, i in impacts)
    assert all(i.approach_speed < 0.8 * first.approach_speed for _, i in impacts[1:])
    assert all(step < 60 for step, _ in impacts)
    position = world.pose("upper")[0]
    assert position[1] == pytest.approx(0.3, abs=2e-3)
    assert np.linalg.norm(world.velocity("upper")[1]) < 1e-2  # rad/s: no spin
    # On the lower crate still (the turned one lands about 1 cm aside: ODE's contacts of two
    # meshes within the slack are not all the faces' own).
    assert abs(position[0] - 0.01) < 0.02 and abs(position[2]) < 0.02
    world.close()


def _mesh_shape():
    """A mesh file's shape (ODE gets the triangles passed with it)."""
    from dentdemo.model.shapes import MeshFile

    return MeshFile("crate.obj")
