"""The sandbox: deterministic headless renders, dents visible only where impacts were, the real
window under Xvfb, and the panel's actions through the controller API."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from cli_helpers import dentdemo, python_json
from dentdemo.app.controller import DemoController
from dentdemo.app.headless import render_headless
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
from dentdemo.render.camera import OrbitCamera

ROOT = Path(__file__).resolve().parents[1]
BALL_DROP = ROOT / "assets" / "scenes" / "ball_drop.toml"
SIZE = (480, 270)
#: ball_drop's first bounces (frames 19-32) are carved and in view by then.
FRAMES = 45


def _png(path: Path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB"), dtype=np.int16)


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    out = tmp_path_factory.mktemp("renders")
    paths = {}
    for name, denting in (("a", True), ("b", True), ("flat", False)):
        paths[name] = out / f"{name}.png"
        render_headless(BALL_DROP, [], FRAMES, paths[name], SIZE, denting=denting)
    return paths


@pytest.mark.slow
def test_headless_render_is_pixel_identical_twice(renders):
    a, b = _png(renders["a"]), _png(renders["b"])
    assert a.shape == (SIZE[1], SIZE[0], 3)
    np.testing.assert_array_equal(a, b)
    assert a.std() > 10  # a scene, not a blank image


@pytest.mark.slow
def test_dents_change_the_image_only_near_impacts(renders, gl):
    dented, flat = _png(renders["a"]), _png(renders["flat"])
    changed = np.abs(dented - flat).sum(axis=2) > 24
    assert changed.sum() > 20, "dents must be visible"
    # Where were the dents carved? Re-run the same deterministic simulation and project them.
    lib = load_materials()
    scene = load_scene(BALL_DROP, lib)
    from dentdemo.app.simulation import Simulation
    from dentdemo.physics.world import pose_matrix

    sim = Simulation(gl, scene, lib)
    carried = []  # (body, the impact point in that body's frame at the impact)
    for _ in range(FRAMES):
        for impact in sim.step():
            for body, pose in ((impact.body_a, impact.pose_a), (impact.body_b, impact.pose_b)):
                local = np.linalg.inv(pose_matrix(*pose)) @ np.append(impact.point, 1.0)
                carried.append((body, local))
    # A dent moves with its body: where each impact's point on each body is now (a ball that
    # rolled on shows its dent away from where it was carved), and where it was carved.
    moved = [(sim.model(body) @ local)[:3] for body, local in carried if body in sim.bodies]
    points = np.array([*sim.carved_points, *moved])
    camera = OrbitCamera.from_eye(scene.camera.eye, scene.camera.target, scene.camera.fov_deg)
    pixels = camera.project(points, SIZE[0] / SIZE[1], SIZE)
    ys, xs = np.nonzero(changed)
    dist = np.min(
        np.hypot(xs[:, None] - pixels[None, :, 0], ys[:, None] - pixels[None, :, 1]), axis=1
    )
    # Every changed pixel lies within 35 px (a dent plus the ball sitting in it: a ball whose
    # collision shape follows a deep dent sits on its flat, its whole outline lower) of an impact.
    assert np.percentile(dist, 99) < 35 and dist.max() < 45
    sim.close()


@pytest.mark.slow
def test_render_writes_every_frame_and_maps(tmp_path):
    out = tmp_path / "frame_%04d.png"
    result = dentdemo(
        "render",
        "--frames",
        "3",
        "--out",
        str(out),
        "--size",
        "64x48",
        "--maps-dir",
        str(tmp_path / "maps"),
    )
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in tmp_path.glob("frame_*.png")) == [
        "frame_0000.png",
        "frame_0001.png",
        "frame_0002.png",
    ]
    height = np.load(tmp_path / "maps" / "steel_plate_height.npy")
    assert height.dtype == np.float32 and height.shape == (512, 512)
    assert (tmp_path / "maps" / "steel_plate_normal.png").is_file()


@pytest.mark.parametrize(
    "args,fragment",
    [
        (["--size", "big"], "--size"),
        (["--frames", "0"], "--frames"),
        (["--scene", "/nonexistent.toml"], "/nonexistent.toml"),
    ],
)
@pytest.mark.slow
def test_render_bad_arguments(tmp_path, args, fragment):
    result = dentdemo("render", "--out", str(tmp_path / "x.png"), *args)
    assert result.returncode != 0 and fragment in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x.png").exists()


@pytest.mark.slow
def test_panel_actions_through_the_controller(gl, tmp_path):
    lib = load_materials()
    app = DemoController(gl, load_scene(BALL_DROP, lib), lib, (320, 180))
    before = len(app.sim.bodies)
    # Drop: a ball 1 m above the floor point under the screen centre.
    app.panel.ball_material, app.panel.ball_radius = "copper", 0.03
    ball = app.tools.drop_ball(0.0, 0.0)
    assert ball is not None and len(app.sim.bodies) == before + 1
    spec = app.sim.bodies[ball].spec
    assert spec.material.name == "copper" and spec.shape.radius == 0.03
    floor = app.tools.ground_point(0.0, 0.0)
    np.testing.assert_allclose(spec.position, floor + [0, 1.0, 0], atol=1e-9)
    # Throw: along the view ray at the panel's speed.
    app.panel.throw_speed = 5.0
    thrown = app.tools.throw_ball(0.1, -0.1)
    v = np.array(app.sim.bodies[thrown].spec.velocity)
    assert np.linalg.norm(v) == pytest.approx(5.0)
    _, direction = app.view.camera.ray(0.1, -0.1, app.view.renderer.aspect)
    np.testing.assert_allclose(v / 5.0, direction, atol=1e-9)
    # Plate of the panel's material under the orbit target.
    app.panel.plate_material = "copper"
    plate = app.tools.add_plate()
    body = app.sim.bodies[plate]
    assert body.spec.material.name == "copper" and body.spec.static
    # A 0.5 m plate at 1024 texels/m: a 512^2 map; its top face at y = 0.02 under the target.
    assert body.maps.size == (512, 512)
    np.testing.assert_allclose(
        body.spec.position, (app.view.camera.target[0], 0.02, app.view.camera.target[2]), atol=1e-12
    )
    # Pause, single step, time scale.
    app.toggle_pause()
    t = app.sim.world.time
    assert app.update(0.5) == 0 and app.sim.world.time == t
    app.single_step()
    assert app.sim.world.time == pytest.approx(t + app.sim.scene.physics.dt)
    app.toggle_pause()
    app.set_time_scale(0.5)
    assert app.update(4 * app.sim.scene.physics.dt) == 2
    # Views and toggles render without error.
    for view in (0, 1, 2):
        app.view.set_view(view)
        app.view.render()
    for name in ("parallax", "wireframe", "contacts", "address_map", "shadows"):
        app.view.toggle(name)
        app.view.render()
    shot = app.screenshot(tmp_path / "shot.png")
    assert Image.open(shot).size == (320, 180)
    # Reset: back to the scene's bodies.
    app.reset()
    assert len(app.sim.bodies) == before and app.sim.world.time == 0.0
    app.close()


@pytest.mark.slow
def test_the_frame_loop_freezes_the_loaded_scene_and_a_reset_collects_the_old(gl):
    """Once a frame loop starts, what is alive (the loaded scene among it) is frozen out of the
    garbage collector's scans (app/heap.py): a cycle made before it outlives `gc.collect`, as
    frozen objects do, and a reset, which drops the old bodies, frees it (no leak across resets);
    frames still run."""
    import gc
    import weakref

    from dentdemo.app.loop import FrameLoop, ImageBackend

    class Node:
        other: object = None

    lib = load_materials()
    app = DemoController(gl, load_scene(BALL_DROP, lib), lib, (64, 48))
    try:
        a, b = Node(), Node()
        a.other, b.other = b, a  # a reference cycle: only the collector frees it
        alive = weakref.ref(a)
        gc.unfreeze()
        assert gc.get_freeze_count() == 0
        loop = FrameLoop(app, ImageBackend((64, 48), None), fixed_dt=True)
        assert gc.get_freeze_count() > 10_000  # the modules, the scene, its bodies
        del a, b
        gc.collect()
        assert alive() is not None  # frozen: not scanned, so not freed
        app.reset()
        assert alive() is None  # the reset unfroze and collected it
        assert gc.get_freeze_count() > 10_000
        loop.frame()
    finally:
        app.close()
        gc.unfreeze()


def test_impact_queue_never_drops_a_hit(gl):
    lib = load_materials()
    scene = load_scene(BALL_DROP, lib)
    from dentdemo.app.simulation import Simulation

    sim = Simulation(gl, scene, lib, carve_budget=1)
    for i in range(30):  # a burst: 30 balls side by side, dropped together
        sim.drop_ball((-0.5 + i * 0.035, 0.3, -0.3), material="steel", radius=0.015)
    total_requests = 0
    for _ in range(40):
        before = len(sim.queue) + sim.stats.hits
        sim.step()
        total_requests += len(sim.queue) + sim.stats.hits - before
        assert sim.stats.hits <= sim.stats.frames  # the budget holds
    while sim.queue:
        sim.step()
    assert sim.stats.hits >= total_requests > 10
    sim.close()


def test_the_work_the_sandbox_runs_beside_its_gathers_makes_no_gl_call(gl, monkeypatch):
    """The simulation tells its carver that its `meanwhile` (the dents' statistics and the
    collision proxies' presses) makes no GL call, so that the batch keeps what it knows of the
    GL state: through 60 frames of dropped balls, every such call raises (moderngl's objects and
    the raw GL library), the batches still carve, and their maps are those of a run that lets
    the batch set its state again."""
    import moderngl

    from dentdemo.app.simulation import Simulation
    from dentdemo.carve.carver import Carver
    from dentdemo.gl.library import gl_library

    lib = load_materials()
    scene = load_scene(BALL_DROP, lib)
    runs: list[int] = []
    plain = type(gl_library())

    def refuse(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        raise AssertionError("a GL call in the work run beside the gathers")

    class Refusing(plain):  # type: ignore[valid-type, misc]
        def __getattribute__(self, name: str):  # noqa: ANN204
            if name.startswith("gl"):
                refuse()
            return plain.__getattribute__(self, name)

    carve_many = Carver.carve_many

    def checked(self, presses, meanwhile=None, **kwargs):  # noqa: ANN001, ANN003, ANN202
        def guarded() -> None:
            runs.append(kwargs.get("meanwhile_uses_gl", True))
            with monkeypatch.context() as patch:
                for cls in (
                    moderngl.Context,
                    moderngl.Texture,
                    moderngl.Framebuffer,
                    moderngl.Buffer,
                    moderngl.VertexArray,
                    moderngl.Program,
                ):
                    for name, member in list(vars(cls).items()):
                        if callable(member) and not name.startswith("__"):
                            patch.setattr(cls, name, refuse)
                library = gl_library()
                library.__class__ = Refusing
                try:
                    meanwhile()
                finally:
                    library.__class__ = plain

        return carve_many(self, presses, None if meanwhile is None else guarded, **kwargs)

    def run(guard: bool) -> list[bytes]:
        sim = Simulation(gl, scene, lib)
        for i in range(6):
            sim.drop_ball((-0.3 + i * 0.12, 0.25, 0.0), material="steel", radius=0.03)
        with monkeypatch.context() as patch:
            if guard:
                patch.setattr(Carver, "carve_many", checked)
            else:  # the batch told nothing: it sets the state again after the host's work
                patch.setattr(
                    Carver,
                    "carve_many",
                    lambda self, presses, meanwhile=None, **kw: carve_many(
                        self, presses, meanwhile
                    ),
                )
            for _ in range(60):
                sim.step()
        assert sim.stats.hits > 0
        maps = [
            gl.read(body.maps.height).tobytes() + gl.read(body.maps.normal).tobytes()
            for body in sim.bodies.values()
            if body.maps is not None
        ]
        sim.close()
        return maps

    guarded_maps = run(True)
    assert runs and not any(runs)  # ran, promised to make no GL call
    assert guarded_maps == run(False)


@pytest.mark.slow
def test_real_window_screenshot_under_xvfb(xvfb, tmp_path):
    shot = tmp_path / "shot.png"
    env = {**os.environ, "DISPLAY": xvfb}
    result = dentdemo(
        "demo",
        "--scene",
        str(BALL_DROP),
        "--screenshot",
        str(shot),
        "--exit-after",
        "1",
        env=env,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    image = _png(shot)
    assert image.shape == (720, 1280, 3)
    # The scene and the panel are there: many distinct colours, the panel's dark box top left.
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 500
    assert image[30:200, 20:250].mean() < image[400:700, 500:1200].mean()


_WINDOW_FRAMEBUFFER = """
import ctypes, json, sys
from dentdemo.app.window import DemoWindow
from dentdemo.gl.library import gl_library as _gl
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
lib = load_materials()
window = DemoWindow(load_scene(sys.argv[1], lib), lib, (320, 180), "low")
window.gl.ctx.screen.use()
values = {}
for name, pname in (("samples", 0x80A9), ("depth_bits", 0x0D56)):  # GL_SAMPLES, GL_DEPTH_BITS
    out = ctypes.c_int(-1)
    _gl().glGetIntegerv(pname, ctypes.byref(out))
    values[name] = out.value
window.close()
print(json.dumps(values))
"""


@pytest.mark.slow
def test_window_framebuffer_is_single_sampled_without_depth(xvfb):
    """The window only receives finished frames. A multisampled default framebuffer (glfw's
    old default here was 4 samples) made every touch of the screen and every swap resolve 4
    samples: on llvmpipe under Xvfb, 5.9 ms per swap instead of 0.3."""

    env = {**os.environ, "DISPLAY": xvfb}
    values = python_json(_WINDOW_FRAMEBUFFER, BALL_DROP, env=env)
    assert values == {"samples": 0, "depth_bits": 0}


@pytest.mark.slow
def test_demo_without_display_renders_headless(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = dentdemo(
        "demo",
        "--screenshot",
        str(tmp_path / "d.png"),
        "--exit-after",
        "0.2",
        env=env,
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    assert "no display" in result.stderr and "headless" in result.stderr
    assert Image.open(tmp_path / "d.png").size == (1280, 720)


def test_close_up_frames_the_last_hit(gl):
    """Key F / panel button: the camera 0.3 m from the last hit, 40 degrees above its contact
    plane; the panel names the deeper dent in millimetres."""
    lib = load_materials()
    app = DemoController(gl, load_scene(BALL_DROP, lib), lib, (160, 90))
    try:
        assert not app.view.close_up() and app.view.last_dent_text() == "no dent yet"
        while app.sim.last_hit is None:
            app.sim.step()
        request = app.sim.last_hit
        hit = request.impact
        assert app.view.close_up()
        offset = app.view.camera.eye - hit.point
        np.testing.assert_allclose(app.view.camera.target, hit.point, atol=1e-12)
        assert np.linalg.norm(offset) == pytest.approx(0.3, rel=1e-9)
        up = hit.normal if hit.normal[1] >= 0 else -hit.normal
        elevation = np.degrees(np.arcsin(offset @ up / np.linalg.norm(offset)))
        assert elevation == pytest.approx(40.0, abs=1e-6)
        # The deeper dent, from the maps themselves (only this hit has been carved) and from
        # eq. 4 with each material's k and Y worked out of the materials file by hand.
        text = app.view.last_dent_text().split()
        assert text[:2] == ["last", "dent"] and text[3:6] == ["mm", "deep", "in"]
        shown_mm, shown_body = float(text[2]), text[6]
        carved = {
            name: float(-gl.read(app.sim.bodies[name].maps.height)[:, :, 0].min())
            for name in (hit.body_a, hit.body_b)
        }
        assert shown_body == max(carved, key=carved.get) and carved[shown_body] > 0
        assert shown_mm == pytest.approx(carved[shown_body] * 1e3, rel=0.03)
        raw = tomllib.loads((ROOT / "assets" / "materials.toml").read_text())
        cal, model = raw["calibration"], {}
        for name in (hit.body_a, hit.body_b):
            m = raw["materials"][app.sim.bodies[name].spec.material.name]
            k = m.get("k_m_per_Ns") or cal["k_per_compliance"] * (
                1 / m["plastic_modulus_Pa"] - 1 / m["youngs_modulus_Pa"]
            )
            y = cal["Y_unit_Ns"] * (1 / (1 - m["restitution"]) - 1)
            model[name] = min(m["max_dent_depth_m"], k * max(0.0, abs(hit.j_elastic) - y))
        assert shown_body == max(model, key=model.get)
        assert shown_mm == pytest.approx(model[shown_body] * 1e3, abs=0.006)
    finally:
        app.close()


def test_quality_switches_while_the_scene_runs(gl):
    """The panel's "quality": the renderer is rebuilt at the preset's shading size (low shades
    0.45 of each axis: 144 x 81 for 320 x 180; high all of it), the simulation is untouched, and
    the frame still renders the scene."""
    materials = load_materials()
    app = DemoController(gl, load_scene(BALL_DROP, materials), materials, (320, 180), quality="low")
    try:
        for _ in range(5):
            app.sim.step()
        time_before, bodies = app.sim.world.time, set(app.sim.bodies)
        assert app.view.renderer.shade_size == (144, 81)
        app.view.set_quality("high")
        assert app.view.quality.name == "high" and app.view.renderer.shade_size == (320, 180)
        assert app.view.renderer.size == (320, 180)
        assert app.sim.world.time == time_before and set(app.sim.bodies) == bodies
        app.view.render()
        image = app.view.renderer.read_rgb()
        assert len(np.unique(image.reshape(-1, 3), axis=0)) > 200
    finally:
        app.close()


def test_a_body_s_first_hit_builds_no_mesh_query_structures(gl, monkeypatch):
    """A dropped ball's clusters, uv derivatives, chart borders and closedness are built when
    the ball is made, not in the frame of its first hit (they cost ~2 ms a ball there)."""
    from dentdemo.app.simulation import Simulation
    from dentdemo.mesh import mesh as mesh_module

    lib = load_materials()
    sim = Simulation(gl, load_scene(BALL_DROP, lib), lib)
    ball = sim.drop_ball((0.0, 0.1, 0.0), velocity=(0.0, -3.0, 0.0), radius=0.02)

    def built(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("a mesh query structure was built during a carve")

    # The clusters' and the closedness's builders (a new mesh's tangents, as a collision
    # proxy's at a first dent, use the uv derivatives: those are left to the reached counts).
    monkeypatch.setattr(mesh_module, "_morton_order", built)
    monkeypatch.setattr("dentdemo.model.shapes.mesh_volume", built)
    derived = mesh_module.Mesh.triangle_derivatives
    reached: list[int] = []

    def derivatives(self, which=None):  # noqa: ANN001, ANN202 - Mesh.triangle_derivatives
        if getattr(self, "_derivative_cache", None) is None:
            reached.append(id(self))
        return derived(self, which)

    monkeypatch.setattr(mesh_module.Mesh, "triangle_derivatives", derivatives)
    for _ in range(40):
        sim.step()
    assert sim.stats.hits > 0  # the ball landed and was carved
    assert id(sim.bodies[ball].mesh) not in reached
    sim.close()


@pytest.mark.parametrize(
    ("scene", "drop"),
    [
        ("ball_drop.toml", (0.0, 0.1, 0.0)),  # a ball onto the plates' corner: balls and plates
        ("ball_drop.toml", (-0.25, 0.22, -0.75)),  # onto the steel block: a box
        ("crates.toml", (-0.12, 0.35, 0.0)),  # onto a crate: a loaded mesh that may hide itself
    ],
    ids=["plates", "box", "loaded-mesh"],
)
def test_a_body_s_first_hit_makes_no_vertex_array_or_index_stream(gl, scene, drop):
    """Every body's index streams and the vertex arrays of the programs that may draw its
    triangle lists are made with the body (Carver.prepare), not in the frame of its first hit:
    the hits of a dropped ball leave each body's count of both as it was when it was made."""
    from dentdemo.app.simulation import Simulation

    lib = load_materials()
    sim = Simulation(gl, load_scene(ROOT / "assets" / "scenes" / scene, lib), lib)
    try:
        sim.drop_ball(drop, velocity=(0.0, -3.0, 0.0), radius=0.02)

        def counts() -> dict[str, tuple[int, int]]:
            return {
                key: (len(body.gpu_mesh._vaos), len(body.gpu_mesh._subsets))
                for key, body in sim.bodies.items()
            }

        made = counts()
        for _ in range(40):
            sim.step()
        assert sim.stats.hits > 0 and len(sim.dents) >= 1  # the ball landed and was carved
        after = counts()
        assert after == made, {k: (made[k], v) for k, v in after.items() if v != made[k]}
    finally:
        sim.close()


@pytest.mark.parametrize(
    ("scene", "drops"),
    [
        # Balls onto the plates, the steel block and each other: spheres (their chart lists, gutters
        # and texel rectangles, drawn as quads as tools), plates and a box as targets and tools.
        (
            "ball_drop.toml",
            [(0.0, 0.1, 0.0), (-0.25, 0.22, -0.75), (0.3, 0.2, 0.3), (0.3, 0.3, 0.3)],
        ),
        # Onto crates: a loaded mesh that may hide part of itself (pass 2).
        ("crates.toml", [(-0.12, 0.35, 0.0), (0.1, 0.4, 0.05)]),
    ],
    ids=["ball-drop", "crates"],
)
@pytest.mark.slow
def test_every_pass_a_hit_draws_a_body_with_is_one_the_body_was_made_and_warmed_for(
    gl, scene, drops
):
    """Carver.prepare (the vertex arrays and index streams) and Carver.warm (the shader
    variants) make what a body's hits will draw from one list of the passes that may draw it
    (`Carver._body_draws`). Every draw of the hits here is checked against that list: the pass
    drawn, and the body it draws, found by the map it samples (a gather reads its target's mask,
    a normal rebuild its target's heights, pass 2 its target's and pass 3 its tool's)."""
    from contextlib import contextmanager

    from dentdemo.app.simulation import Simulation
    from dentdemo.carve import carver as carver_module
    from dentdemo.carve.texel_passes import RECT

    lib = load_materials()
    sim = Simulation(gl, load_scene(ROOT / "assets" / "scenes" / scene, lib), lib)
    drawn: list[tuple[object, object]] = []  # (pass, the sampled texture)
    real = carver_module.shared_batch

    @contextmanager
    def recording(ctx, fbo, state, *held):  # noqa: ANN001, ANN002, ANN202 - shared_batch's own
        with real(ctx, fbo, state, *held) as one:

            def record(pass_, viewport, draw, textures=(), *rest, **named):  # noqa: ANN001, ANN202
                drawn.append((pass_, textures))
                return one(pass_, viewport, draw, textures, *rest, **named)

            yield record

    carver_module.shared_batch = recording
    try:
        for k, drop in enumerate(drops):
            # 512 texels a metre, as the bench's balls: some hits' texels are drawn as rectangles.
            sim.drop_ball(drop, (0.0, -3.0, 0.0), radius=0.015 + 0.01 * k, texels_per_metre=512)
        for _ in range(60):
            sim.step()
    finally:
        carver_module.shared_batch = real
    try:
        assert sim.stats.hits >= len(drops)
        by_texture = {}
        for body in sim.bodies.values():
            by_texture[id(body.maps.height)] = by_texture[id(body.maps.mask)] = body
        kinds = set()
        for pass_, textures in drawn:
            body = next(by_texture[id(t)] for t in textures if id(t) in by_texture)
            listed = {p for _, p, _ in sim.carver._body_draws(body.mesh)}
            assert pass_ in listed, (pass_.name, body.spec.id)
            kinds.add((pass_.name, body.mesh.name))
        names = {name for name, _ in kinds}
        assert {"peel", "gather", "normals"} <= names and len(kinds) >= 5, kinds
        rects = {sim.carver._texel[key] for key in (("gather", RECT, True, True, True),)}
        assert scene != "ball_drop.toml" or any(p in rects for p, _ in drawn)  # texel rectangles
        if scene == "crates.toml":
            assert "address" in names  # a loaded mesh that may hide part of itself
    finally:
        sim.close()


@pytest.mark.slow
def test_warming_a_body_changes_no_texel_and_gives_the_state_back(gl):
    """Carver.warm draws every pass that may draw a body into an empty viewport: the body's
    height and normal maps, dented before, are the same bytes after a carver that has warmed
    nothing yet warms every variant for them, and the host's GL state is as it was."""
    from dentdemo.app.simulation import Simulation
    from dentdemo.carve.carver import Carver
    from test_host_state import cache_mismatches, driver_state, host_read

    lib = load_materials()
    sim = Simulation(gl, load_scene(BALL_DROP, lib), lib)
    fresh = Carver(sim.gl)
    try:
        ball = sim.drop_ball((0.0, 0.1, 0.0), velocity=(0.0, -3.0, 0.0), radius=0.02)
        for _ in range(40):
            sim.step()
        assert sim.dents.get(ball) is not None  # a dented sphere, and a dented plate under it
        bodies = [sim.bodies[ball], *(b for b in sim.bodies.values() if b.spec.id != ball)]
        before = [(host_read(b.maps.height), host_read(b.maps.normal)) for b in bodies]
        assert any(h.view(np.float32).min() < 0 for h, _ in before[:1])
        ctx = sim.gl.ctx
        ctx.viewport = (3, 4, 50, 60)
        ctx.enable(ctx.BLEND | ctx.DEPTH_TEST)
        state = driver_state()
        for body in bodies:
            fresh.warm(body.gpu_mesh, body.maps)
        assert fresh._warmed  # it warmed some kinds of body, each once
        assert driver_state() == state and not cache_mismatches(ctx)
        after = [(host_read(b.maps.height), host_read(b.maps.normal)) for b in bodies]
        for (h0, n0), (h1, n1), body in zip(before, after, bodies, strict=True):
            assert np.array_equal(h0, h1) and np.array_equal(n0, n1), body.spec.id
    finally:
        fresh.release()
        sim.close()


def test_the_address_map_view_draws_pass_2_for_convex_targets_too(gl):
    """Pass 2 is left out for built-in targets (docs/carve.md), but the address-map view shows
    it: with the view on, the last carve's tile holds the surface's (u, v) and view depths."""
    lib = load_materials()
    app = DemoController(gl, load_scene(BALL_DROP, lib), lib, (320, 180))
    app.view.toggle("address_map")
    app.view.render()
    app.sim.drop_ball((0.0, 0.1, 0.0), velocity=(0.0, -3.0, 0.0), radius=0.02)
    for _ in range(40):
        app.sim.step()
        if app.sim.stats.hits:
            break
    assert app.sim.stats.hits > 0
    job = app.sim.carver.last_jobs[0]
    address = gl.read_region(app.sim.carver.scratch.address_fbo, job.viewport, 4, 0)
    u, v, depth = address[..., 0], address[..., 1], address[..., 2]
    seen = (u > 0.0) & (u < 1.0) & (v > 0.0) & (v < 1.0) & (depth > 0.0)
    assert seen.any()  # the target's surface in the slab (pass 2 clears its tiles to -1)
    app.close()


def test_bodies_of_one_shape_share_one_mesh_until_the_last_goes(gl):
    """Balls of one radius draw with one mesh and one set of buffers, and one set of coarser
    render meshes (a ball's first carve then finds the vertex arrays and index streams the balls
    before it made); another radius has its own. The buffers outlive every body but the last
    that holds them, which deletes them."""
    import moderngl

    from dentdemo.app.scenery import Scenery
    from dentdemo.app.simulation import Simulation

    lib = load_materials()
    sim = Simulation(gl, load_scene(BALL_DROP, lib), lib)
    scenery = Scenery(gl)
    try:
        a, b = (
            sim.drop_ball((x, 0.1, 0.0), velocity=(0.0, -3.0, 0.0), radius=0.02)
            for x in (-0.1, 0.1)
        )
        c = sim.drop_ball((0.0, 0.1, 0.1), velocity=(0.0, -3.0, 0.0), radius=0.03)
        first, second, other = (sim.bodies[k] for k in (a, b, c))
        assert second.gpu_mesh is first.gpu_mesh and second.mesh is first.mesh
        assert other.gpu_mesh is not first.gpu_mesh and other.mesh is not first.mesh
        assert first.maps is not second.maps  # each its own dents
        parts = scenery.sync(sim)
        assert parts[a] is parts[b] and parts[c] is not parts[a] and parts[a].coarser
        buffers = [first.gpu_mesh.vbo, first.gpu_mesh.ibo, parts[a].coarser[0].mesh.vbo]
        others = [other.gpu_mesh.vbo, parts[c].coarser[0].mesh.vbo]

        def deleted(buffer: moderngl.Buffer) -> bool:
            return isinstance(buffer.mglo, moderngl.mgl.InvalidObject)

        sim.remove_body(a)
        scenery.sync(sim)
        assert not any(map(deleted, buffers))
        for _ in range(40):  # the ball left lands and is carved with the shared buffers
            sim.step()
        assert sim.dents.get(b) is not None and sim.dents[b].count > 0
        sim.remove_body(b)
        scenery.sync(sim)
        assert all(map(deleted, buffers)) and not any(map(deleted, others))
    finally:
        scenery.release()
        sim.close()
    assert all(map(deleted, others))
