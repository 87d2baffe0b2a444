"""Wear from the physics (issue 44): each step, a sliding pair's normal force (ODE's joint
feedback) times its slip; held to a ball's skid in closed form, and to pure rolling's zero."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene
from dentdemo.physics.simulate import build_world
from scene_text import ball, plate, steel_like

G = 9.81
RADIUS = 0.04  # m
MU = 0.5
WEARING = steel_like("worn", 0.01, "wear_coefficient = 1e-3\nhardness_Pa = 1e9\n")
PHYSICS = "[physics]\ngravity = [0.0, -9.81, 0.0]\nwear_scale = {scale}\n"


def _world(tmp_path, scale: float = 1.0):
    materials = tmp_path / "m.toml"
    materials.write_text(WEARING)
    scene_path = tmp_path / "s.toml"
    position = f"[0.0, {0.02 + RADIUS}, 0.0]"
    scene_path.write_text(
        "\n".join([PHYSICS.format(scale=scale), plate("worn", side=4.0), ball("worn", position)])
    )
    return build_world(load_scene(scene_path, load_materials([materials])))


def _settled(world):
    for _ in range(10):  # onto the plate first
        world.step()
    return world


@pytest.mark.parametrize("speed", [1.0, 2.0])
def test_a_skidding_ball_slips_v0_squared_over_7_mu_g(tmp_path, speed):
    """A ball thrown along +x without spin skids until it rolls: its slip speed v0 - 7/2 mu g t
    falls to 0 at t = 2 v0 / (7 mu g), over a slip of v0^2 / (7 mu g), all under its weight
    m g; then it rolls and slips no more."""
    world = _settled(_world(tmp_path))
    try:
        world.set_velocity("ball", (speed, 0.0, 0.0), (0.0, 0.0, 0.0))
        mass = world.bodies["ball"].mass
        slip = work = 0.0
        rolled_at = None
        for step in range(round(1.0 / world.spec.dt)):
            world.step()
            slide = world.slides.get(("plate", "ball"))
            if slide is None:
                rolled_at = rolled_at if rolled_at is not None else step
                continue
            assert rolled_at is None, "it slid again after rolling"
            slip += slide.slip
            work += slide.work
            assert slide.normal == pytest.approx([0.0, 1.0, 0.0], abs=1e-6)
        expected = speed**2 / (7 * MU * G)
        assert slip == pytest.approx(expected, rel=0.03)
        assert work == pytest.approx(mass * G * expected, rel=0.03)
        assert rolled_at is not None
        assert rolled_at * world.spec.dt == pytest.approx(2 * speed / (7 * MU * G), abs=0.04)
    finally:
        world.close()


def test_a_ball_rolling_without_slip_slides_nowhere(tmp_path):
    world = _settled(_world(tmp_path))
    try:
        v = 1.0
        world.set_velocity("ball", (v, 0.0, 0.0), (0.0, 0.0, -v / RADIUS))
        for _ in range(60):
            world.step()
            assert not world.slides
        assert np.linalg.norm(world.velocity("ball")[0]) == pytest.approx(v, rel=0.01)
    finally:
        world.close()


def test_without_wear_scale_nothing_is_tracked(tmp_path):
    world = _settled(_world(tmp_path, scale=0.0))
    try:
        world.set_velocity("ball", (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        world.step()
        assert not world.slides and not world._feedback
    finally:
        world.close()


def test_the_physics_wear_scale_is_validated(tmp_path):
    from dentdemo.errors import ConfigError

    with pytest.raises(ConfigError, match="wear_scale"):
        _world(tmp_path, scale=-1.0)
    assert math.isfinite(load_materials().get("steel").hardness)


def _sandbox(gl, tmp_path, scale: float):
    from dentdemo.app.simulation import Simulation

    tmp_path.mkdir(parents=True, exist_ok=True)
    materials = tmp_path / "m.toml"
    materials.write_text(WEARING)
    scene_path = tmp_path / "s.toml"
    position = f"[-0.3, {0.02 + RADIUS}, 0.0]"
    scene_path.write_text(
        "\n".join(
            [
                PHYSICS.format(scale=scale),
                plate("worn", side=1.0, texels=1024),
                ball("worn", position, texels=256),
            ]
        )
    )
    lib = load_materials([materials])
    return Simulation(gl, load_scene(scene_path, lib), lib)


def _plate_heights(sim) -> np.ndarray:
    return sim.gl.read(sim.bodies["plate"].maps.height)[:, :, 0].astype(np.float64)


@pytest.mark.parametrize("speed", [1.5, 2.0])
def test_a_skidding_ball_scratches_archards_volume_until_it_rolls(gl, tmp_path, speed):
    """Thrown along +x without spin, a ball wears the plate K (m g) v0^2 / (7 mu g) / H times
    the scene's scale while it skids (its slip, in closed form), along the path it travels
    until it rolls: v0 t - mu g t^2 / 2 at t = 2 v0 / (7 mu g); then nothing more."""
    scale = 1e5
    sim = _sandbox(gl, tmp_path, scale)
    try:
        for _ in range(10):
            sim.step()
        before = _plate_heights(sim)
        sim.world.set_velocity("ball", (speed, 0.0, 0.0), (0.0, 0.0, 0.0))
        start_x = sim.world.pose("ball")[0][0]
        for _ in range(90):
            sim.step()
        sim.apply_queued()
        after = _plate_heights(sim)
        mass = sim.world.bodies["ball"].mass
        texel = 1.0 / after.shape[0]
        worn = -(after - before).sum() * texel * texel
        expected = scale * 1e-3 * mass * G * speed**2 / (7 * MU * G) / 1e9
        assert sim.wear is not None
        assert sim.wear.worn["plate"] == pytest.approx(expected, rel=0.03)
        # Carved: the segments' grooves plus their end caps (a few per cent of the whole).
        assert worn == pytest.approx(expected, rel=0.1)
        t_roll = 2 * speed / (7 * MU * G)
        end_x = start_x + speed * t_roll - MU * G * t_roll**2 / 2
        cols = np.nonzero((after - before < 0).any(axis=0))[0]
        x = (cols + 0.5) * texel - 0.5  # the plate's u runs along +x, centred at x = 0
        assert x.min() == pytest.approx(start_x, abs=0.01)
        deepest = -(after - before).min()
        cap = math.sqrt(2 * RADIUS * deepest)  # the groove's last end cap reaches past its end
        assert x.max() < end_x + cap + 2 * texel  # the groove stops where the slide did
        assert x.max() > end_x - 2 * 0.03  # within two segments of it
    finally:
        sim.close()


def test_a_rolling_ball_leaves_no_scratch(gl, tmp_path):
    sim = _sandbox(gl, tmp_path, 1e5)
    try:
        for _ in range(10):
            sim.step()
        before = _plate_heights(sim)
        v = 1.5
        sim.world.set_velocity("ball", (v, 0.0, 0.0), (0.0, 0.0, -v / RADIUS))
        for _ in range(40):
            sim.step()
        sim.apply_queued()
        assert (_plate_heights(sim) == before).all()
        assert sim.wear is not None and not sim.wear.worn
    finally:
        sim.close()


@pytest.mark.slow
def test_a_scratch_is_undone_with_its_batch_and_bounded_by_the_map(gl, tmp_path):
    """Grooves go through the frame's carve batch: undo takes a frame's groove back bit for bit,
    and a groove deeper than the material's max_dent_depth_m (0.01 m here) stops there."""
    sim = _sandbox(gl, tmp_path, 1e9)  # absurd wear: every segment as deep as allowed
    try:
        for _ in range(10):
            sim.step()
        sim.world.set_velocity("ball", (1.5, 0.0, 0.0), (0.0, 0.0, 0.0))
        before = _plate_heights(sim)
        undone = False
        for _ in range(30):
            sim.step()
            after = _plate_heights(sim)
            if not undone and (after != before).any():
                assert sim.undo()
                assert (_plate_heights(sim) == before).all()
                undone = True
            before = _plate_heights(sim)
        assert undone, "no groove was carved"
        assert before.min() == pytest.approx(-0.01, rel=1e-6)
    finally:
        sim.close()


#: A capsule lying along x on the plate, id "ball" (a prism tool's slide).
CAPSULE = (
    '[[body]]\nid = "ball"\nshape = "capsule"\nradius = 0.03\nlength = 0.1\n'
    'material = "worn"\nposition = [-0.3, 0.05, 0.0]\nrotation_deg = [0, 90, 0]\n'
)


def _skidder(gl, path, tool: str):
    """The plate with a ball (`_sandbox`) or a capsule lying along x, both with id "ball"."""
    if tool == "ball":
        return _sandbox(gl, path, 1e5)
    path.mkdir(parents=True, exist_ok=True)
    return _tool_sandbox(gl, path, 1e5, CAPSULE)


@pytest.mark.parametrize("tool", ["ball", "capsule"])
def test_save_and_resume_mid_slide_is_bit_identical(gl, tmp_path, tool):
    """A ball skidding (a capsule sliding) over segment boundaries, saved part-way through a
    segment and resumed in a new simulation: the plate's heights after as many steps are the
    same bits as one run's, and so is the volume worn (the slide's unfinished segment travels
    in the state, with whether it is the slide's first)."""
    from dentdemo.app.state import load_state, save_state

    def skid(sim, steps):
        for _ in range(steps):
            sim.step()

    one = _skidder(gl, tmp_path / "one", tool)
    try:
        skid(one, 10)
        one.world.set_velocity("ball", (2.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        skid(one, 4)
        assert one.wear is not None and one.wear.tracks  # mid-segment
        save_state(one, tmp_path / "saved")
        skid(one, 26)
        expected, worn = _plate_heights(one), dict(one.wear.worn)
    finally:
        one.close()
    two = _skidder(gl, tmp_path / "two", tool)
    try:
        load_state(two, tmp_path / "saved")
        assert two.wear is not None and two.wear.tracks
        skid(two, 26)
        assert (_plate_heights(two) == expected).all()
        assert (expected < 0).any()
        assert two.wear.worn == worn
    finally:
        two.close()


@pytest.mark.parametrize(
    "change,key",
    [
        (lambda w: w["tracks"][0].update(worn="nobody"), "worn"),
        (lambda w: w["tracks"][0].update(volume=-1.0), "volume"),
        (lambda w: w["tracks"][0].update(normal=[0.0, 2.0, 0.0]), "normal"),
        (lambda w: w["worn"].update(nobody=1.0), "nobody"),
        (lambda w: w["tracks"][0].update(fresh="yes"), "fresh"),
    ],
)
def test_a_saved_slide_is_checked(gl, tmp_path, change, key):
    import json

    from dentdemo.app.state import load_state, save_state
    from dentdemo.errors import DentdemoError

    sim = _sandbox(gl, tmp_path, 1e5)
    try:
        for _ in range(10):
            sim.step()
        sim.world.set_velocity("ball", (2.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        for _ in range(4):
            sim.step()
        path = save_state(sim, tmp_path / "saved")
        payload = json.loads(path.read_text())
        change(payload["wear"])
        path.write_text(json.dumps(payload))
        with pytest.raises(DentdemoError, match=key):
            load_state(sim, tmp_path / "saved")
    finally:
        sim.close()


#: The 1 m plate's texel with 1024 texels a metre, m.
TEXEL = 1.0 / 1024


def _tool_sandbox(gl, tmp_path, scale: float, body: str, materials_text: str = WEARING):
    """The worn 1 m plate (1 mm texels) and one body, `body`'s [[body]] table (id "crate")."""
    from dentdemo.app.simulation import Simulation

    materials = tmp_path / "m.toml"
    materials.write_text(materials_text)
    scene_path = tmp_path / "s.toml"
    scene_path.write_text(
        "\n".join([PHYSICS.format(scale=scale), plate("worn", side=1.0, texels=1024), body])
    )
    lib = load_materials([materials])
    return Simulation(gl, load_scene(scene_path, lib), lib)


def _crate_sandbox(gl, tmp_path, scale: float, yaw_deg: float):
    crate = (
        '[[body]]\nid = "crate"\nshape = "box"\nsize = [0.1, 0.06, 0.06]\nmaterial = "worn"\n'
        f"position = [-0.3, {0.02 + 0.03}, 0.0]\nrotation_deg = [0, {yaw_deg}, 0]\n"
    )
    return _tool_sandbox(gl, tmp_path, scale, crate)


def _slide(gl, tmp_path, scale, body, v0=2.5, materials_text=WEARING):
    """`body` (id "crate", resting on the plate) pushed along +x at v0 without spin until
    friction stops it: the plate's heights lost, the mass, the slide v0^2 / (2 mu g) and
    Archard's volume over it times the scale (checked against the tracker's), and where the
    tool's centre started."""
    sim = _tool_sandbox(gl, tmp_path, scale, body, materials_text)
    try:
        for _ in range(10):
            sim.step()
        before = _plate_heights(sim)
        start_x = sim.world.pose("crate")[0][0]
        sim.world.set_velocity("crate", (v0, 0.0, 0.0), (0.0, 0.0, 0.0))
        for _ in range(70):
            sim.step()
        sim.apply_queued()
        carved = -(_plate_heights(sim) - before)
        mass = sim.world.bodies["crate"].mass
        slide = v0**2 / (2 * MU * G)
        volume = scale * 1e-3 * mass * G * slide / 1e9
        assert sim.wear is not None
        assert sim.wear.worn["plate"] == pytest.approx(volume, rel=0.03)
        assert sim.world.pose("crate")[0][0] - start_x == pytest.approx(slide, rel=0.03)
    finally:
        sim.close()
    return carved, volume, slide, start_x


def _middle(carved, start_x, slide, margin):
    """The carved heights of the columns between start + margin and start + slide - margin (the
    plate's u along +x, x = (u - 1/2) m), and that stretch's length, m."""
    x = (np.arange(carved.shape[1]) + 0.5) / carved.shape[1] - 0.5
    columns = (x > start_x + margin) & (x < start_x + slide - margin)
    return carved[:, columns], columns.sum() / carved.shape[1]


def test_a_capsule_sliding_on_its_side_wears_its_circles_groove(gl, tmp_path):
    """A capsule (r 3 cm, 10 cm between its caps) lying along +x, pushed along its axis: it slips
    v0^2 / (2 mu g) under m g; the groove's cross-section is its circle's segment, so over the
    path's middle the volume per metre is Archard's V / s (within 5 %) and the groove's depth
    the circle's d with A(d) = V / s (the test's own bisection of the integrated circle), its
    profile across the circle's within 8 % of d."""
    r = 0.03
    body = (
        f'[[body]]\nid = "crate"\nshape = "capsule"\nradius = {r}\nlength = 0.1\n'
        f'material = "worn"\nposition = [-0.35, {0.02 + r}, 0.0]\nrotation_deg = [0, 90, 0]\n'
    )
    carved, volume, slide, start_x = _slide(gl, tmp_path, 1e6, body)
    middle, span = _middle(carved, start_x, slide, 0.08)
    assert middle.sum() * TEXEL**2 / span == pytest.approx(volume / slide, rel=0.05)
    depth = _circle_depth(r, volume / slide)
    deepest = middle.max(axis=0)
    assert np.median(deepest) == pytest.approx(depth, rel=0.05)
    z = 0.5 - (np.arange(carved.shape[0]) + 0.5) / carved.shape[0]  # v: z = (1/2 - v) m
    expected = np.maximum(depth - (r - np.sqrt(np.maximum(r * r - z * z, 0.0))), 0.0)
    profile = np.median(middle, axis=1)
    assert np.abs(profile - expected).max() < 0.08 * depth


def _circle_depth(r, area):
    """The depth whose circle segment (the midpoint rule across the circle) is `area`."""
    lo, hi = 0.0, r
    for _ in range(60):
        mid = (lo + hi) / 2
        x = (np.arange(20001) + 0.5) / 20001 * 2 * r - r
        cut = np.maximum(mid - (r - np.sqrt(r * r - x * x)), 0.0).sum() * 2 * r / 20001
        lo, hi = (mid, hi) if cut < area else (lo, mid)
    return (lo + hi) / 2


@pytest.mark.parametrize(
    "shape,width",
    [
        # Upright on a flat end (axis along y): the groove as wide as its diameter.
        ('shape = "cylinder"\nradius = 0.03\nlength = 0.06\nrotation_deg = [90, 0, 0]\n', 0.06),
        # A loaded mesh, the shipped 0.2 m crate scaled to 6 cm: its bottom face's patch.
        ('shape = "mesh"\nmesh = "{crate}"\nscale = 0.3\n', 0.06),
    ],
)
def test_a_flat_faced_tool_wears_a_groove_as_wide_as_its_face(gl, tmp_path, shape, width):
    """A cylinder standing on its end, and a loaded mesh crate on its bottom face, pushed along
    +x: a flat groove as wide as the face across the path, one depth V / (w s) over the path's
    middle (median within 5 %), its volume per metre V / s within 5 %."""
    from dentdemo.resources import assets_dir

    crate = (assets_dir() / "meshes" / "crate.obj").as_posix()
    body = (
        '[[body]]\nid = "crate"\n'
        + shape.format(crate=crate)
        + 'material = "worn"\nposition = [-0.35, 0.0505, 0.0]\n'
    )
    carved, volume, slide, start_x = _slide(gl, tmp_path, 1e6, body)
    middle, span = _middle(carved, start_x, slide, 0.05)
    depth = volume / (width * slide)
    assert np.median(middle[middle > depth / 2]) == pytest.approx(depth, rel=0.05)
    assert middle.sum() * TEXEL**2 / span == pytest.approx(volume / slide, rel=0.05)
    across = (middle > depth / 2).sum(axis=0) * TEXEL  # the groove's width, column by column
    assert np.median(across) == pytest.approx(width, abs=2e-3)


@pytest.mark.parametrize("yaw", [0.0, 30.0])
@pytest.mark.slow
def test_a_sliding_crate_wears_a_flat_groove_as_wide_as_it_is_across(gl, tmp_path, yaw):
    """A 10 x 6 x 6 cm box slid along +x on its face (yawed about y) slips v0^2 / (2 mu g)
    under m g until friction stops it: Archard's volume times the scale, spread over a groove
    as wide as the box is across the path (x |sin| + z |cos| of the yaw), one depth d = V /
    (w s) throughout, whose swept area (the path's plus the box's own print) holds it all."""
    scale, v0 = 1e5, 1.5
    sim = _crate_sandbox(gl, tmp_path, scale, yaw)
    try:
        for _ in range(10):
            sim.step()
        before = _plate_heights(sim)
        sim.world.set_velocity("crate", (v0, 0.0, 0.0), (0.0, 0.0, 0.0))
        for _ in range(40):
            sim.step()
        sim.apply_queued()
        after = _plate_heights(sim)
        mass = sim.world.bodies["crate"].mass
        slide = v0**2 / (2 * MU * G)
        volume = scale * 1e-3 * mass * G * slide / 1e9
        assert sim.wear is not None
        assert sim.wear.worn["plate"] == pytest.approx(volume, rel=0.03)
        t = math.radians(yaw)
        width = 0.1 * abs(math.sin(t)) + 0.06 * abs(math.cos(t))
        depth = volume / (width * slide)
        carved = -(after - before)
        texel = 1.0 / after.shape[0]
        deep = carved[carved > 0.5 * depth]
        assert np.median(deep) == pytest.approx(depth, rel=0.05)
        swept = width * slide + 0.1 * 0.06  # the path's area and the box's own print
        assert carved.sum() * texel * texel == pytest.approx(depth * swept, rel=0.1)
    finally:
        sim.close()


def test_a_swept_box_hull_holds_the_box_and_the_prism_it_sweeps():
    """The hull of a yawed box's corners at both ends of a horizontal segment: its volume is the
    box's plus its cross-section across the motion times the segment (by hand), and it is
    bounded by its own faces, outward."""
    import itertools

    from dentdemo.mesh.hull import hull_mesh

    yaw, shift = 0.3, np.array([0.03, 0.0, 0.01])
    corners = np.array(list(itertools.product([-0.1, 0.1], [-0.05, 0.05], [-0.1, 0.1])))
    c, s = math.cos(yaw), math.sin(yaw)
    corners = corners @ np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]).T
    mesh = hull_mesh(np.vstack([corners, corners + shift]))
    p = mesh.positions.astype(np.float64)[mesh.indices]
    volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6
    motion = math.atan2(shift[2], shift[0])
    across = 0.2 * abs(math.sin(motion + yaw)) + 0.2 * abs(math.cos(motion + yaw))
    assert volume == pytest.approx(0.2 * 0.1 * 0.2 + across * 0.1 * np.linalg.norm(shift))
    assert mesh.bound is not None and len(mesh.bound.triangles) == len(mesh.indices)


@pytest.mark.parametrize("tool", ["ball", "capsule"])
@pytest.mark.slow
def test_a_compact_save_after_a_scratch_holds_it(gl, tmp_path, tool):
    """Compact saves keep a checkpoint and the hit log since it, whose groove records hold the
    scratches (a ball's swept capsule, a capsule's prism): loaded, the maps are the saved run's
    bit for bit, and the run goes on as one that never stopped."""
    from dentdemo.app.state import enable_compact_saves, load_state, save_state

    def skid(sim, steps):
        for _ in range(steps):
            sim.step()

    one = _skidder(gl, tmp_path / "one", tool)
    try:
        enable_compact_saves(one)
        skid(one, 10)
        one.world.set_velocity("ball", (2.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        skid(one, 12)
        saved = _plate_heights(one)
        assert (saved < 0).any()
        save_state(one, tmp_path / "saved")
        skid(one, 20)
        expected = _plate_heights(one)
    finally:
        one.close()
    two = _skidder(gl, tmp_path / "two", tool)
    try:
        enable_compact_saves(two)
        load_state(two, tmp_path / "saved")
        assert (_plate_heights(two) == saved).all()
        skid(two, 20)
        assert (_plate_heights(two) == expected).all()
    finally:
        two.close()


@pytest.mark.parametrize("coat_k", [5e-5, None])
def test_a_harder_coat_keeps_a_sliding_capsules_groove_in_the_paint(gl, tmp_path, coat_k):
    """A capsule (r 3 cm) sliding on its side along its axis over a plate with a 0.1 mm coat.
    The coat wearing 20 times less than the metal for the same work (K 5e-5 against 1e-3, one
    H): the work per metre m g, which would cut A = K m g / H (times the scale) from the bare
    metal, cuts A / 20 from the coat instead, less than the circle's segment at the coat's
    thickness (the test's own integration): over the path's middle the volume per metre is
    A / 20 within 5 % and no texel is deeper than the coat. A coat without a law of its own
    wears as the metal: A per metre, past the coat."""
    r, coat = 0.03, 1e-4
    extra = "wear_coefficient = 1e-3\nhardness_Pa = 1e9\ncoat_thickness_m = 1e-4\n"
    if coat_k is not None:
        extra += f"coat_wear_coefficient = {coat_k}\ncoat_hardness_Pa = 1e9\n"
    body = (
        f'[[body]]\nid = "crate"\nshape = "capsule"\nradius = {r}\nlength = 0.1\n'
        f'material = "worn"\nposition = [-0.35, {0.02 + r}, 0.0]\nrotation_deg = [0, 90, 0]\n'
    )
    materials = steel_like("worn", 0.01, extra)
    carved, volume, slide, start_x = _slide(gl, tmp_path, 1e5, body, materials_text=materials)
    middle, span = _middle(carved, start_x, slide, 0.08)
    per_metre = middle.sum() * TEXEL**2 / span
    x = (np.arange(20001) + 0.5) / 20001 * 2 * r - r
    at_coat = np.maximum(coat - (r - np.sqrt(r * r - x * x)), 0.0).sum() * 2 * r / 20001
    if coat_k is None:
        assert volume / slide > at_coat and per_metre == pytest.approx(volume / slide, rel=0.05)
        assert (carved > coat).sum() > 100
    else:
        assert volume / slide / 20 < at_coat
        assert per_metre == pytest.approx(volume / slide / 20, rel=0.05)
        assert not (carved > coat).any()
