"""A frame's hits carved as one batch (docs/carve.md, "Batches"): every hit reads the heights from
before the batch, so hits whose footprints do not meet give exactly what pressing them one by one
gives, and where footprints overlap a texel takes the deeper of the two hits' values (each worked
out alone, from the same start). Oracle: the same hits pressed one at a time on fresh bodies."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

import dentdemo
from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import Carver, CarverOptions, _Switches
from dentdemo.model.shapes import Box, Capsule, Cylinder, Plate, Sphere
from surface_helpers import (
    DENTED,
    Bodies,
    ball_on,
    heights,
    press_mesh,
    rotation,
    slab_on,
    tilt,
    translation,
)

DOWN = np.array([0.0, -1.0, 0.0])
#: Well apart on a 1 m plate: footprints (and the normals' ring) never meet.
SPOTS = [(-0.3, -0.3), (0.0, -0.3), (0.3, -0.3), (-0.3, 0.2), (0.05, 0.15), (0.3, 0.3)]


def _scene(bodies: Bodies, count: int, radius: float = 0.04):
    plate = bodies.make(press_mesh(Plate(1.0), 2), 512)
    balls = [bodies.make(press_mesh(Sphere(radius), 1), 128) for _ in range(count)]
    return plate, balls


def _presses(plate, balls, spots, depths, radius: float = 0.04):
    presses = []
    for ball, (x, z), depth in zip(balls, spots, depths, strict=True):
        ball.model = translation((x, radius, z))
        presses.append((plate, ball, ContactFrame(np.array([x, 0.0, z]), DOWN), depth, depth / 4))
    return presses


def _maps(gl, body) -> tuple[np.ndarray, np.ndarray]:
    return heights(gl, body), gl.read(body.maps.normal)


@pytest.mark.parametrize("max_resolution", [1023, 40], ids=["one-batch", "atlas-overflow"])
@pytest.mark.slow
def test_disjoint_hits_in_a_batch_equal_one_by_one(gl, max_resolution):
    bodies = Bodies(gl)
    carver = Carver(gl, CarverOptions(max_resolution=max_resolution))
    try:
        depths = [0.004, 0.006, 0.003, 0.008, 0.005, 0.007]
        batched_plate, batched_balls = _scene(bodies, len(SPOTS))
        serial_plate, serial_balls = _scene(bodies, len(SPOTS))
        batch = _presses(batched_plate, batched_balls, SPOTS, depths)
        batches = list(carver.scratch.pack([carver.plan(*press) for press in batch]))
        if max_resolution == 40:  # a 128 x 64 atlas: the twelve cameras do not fit at once
            assert len(batches) >= 2
        else:
            assert len(batches) == 1 and len(batches[0]) == 2 * len(SPOTS)
        carver.carve_many(batch)
        for press in _presses(serial_plate, serial_balls, SPOTS, depths):
            carver.carve(*press)
        for a, b in [(batched_plate, serial_plate), *zip(batched_balls, serial_balls, strict=True)]:
            (ha, na), (hb, nb) = _maps(gl, a), _maps(gl, b)
            assert (ha < DENTED).sum() > 10
            assert np.array_equal(ha, hb) and np.array_equal(na, nb)
        # Each footprint is the one pressed there: six separate dents of the plate.
        h = heights(gl, batched_plate)
        assert -h.min() == pytest.approx(max(depths), rel=0.01)
    finally:
        carver.release()
        bodies.release()


#: Tools of every kind (drawn by pass 3 as one quad: sphere, capsule; as triangles: box,
#: cylinder), their map sides (not all powers of two) and radii.
_TOOLS = [
    (Sphere(0.03), 128),
    (Box((0.08, 0.08, 0.08)), 96),
    (Capsule(0.05, 0.1), 64),
    (Cylinder(0.035, 0.07), 200),
    (Sphere(0.045), 256),
    (Capsule(0.025, 0.025), 128),
]


@pytest.mark.parametrize("degrees", [0.0, 17.0])
def test_a_tools_dent_does_not_depend_on_the_rest_of_its_batch(gl, degrees):
    """Six presses with a tool depth, straight down and tilted: each tool's dent in the batch,
    in the batch reversed, and pressed alone on a fresh scene are the same bits (the plate's
    too: the footprints are apart). Tilted, the plate seen by a tool's camera has a depth
    gradient, where a depth the rasteriser interpolates rounds by where the tile lies."""
    bodies = Bodies(gl)
    carver = Carver(gl)
    press_along = tilt((0.0, 1.0, 0.0), degrees)

    def scene():
        plate = bodies.make(press_mesh(Plate(1.0), 2), 512)
        tools, presses = [], []
        for (shape, size), (x, z) in zip(_TOOLS, SPOTS, strict=True):
            tool = bodies.make(press_mesh(shape, 1), size)
            reach = float(np.max(np.abs(tool.gpu_mesh.mesh.positions[:, 1])))
            tool.model = translation((x, reach, z))
            contact = ContactFrame(np.array([x, 0.0, z]), press_along)
            tools.append(tool)
            presses.append((plate, tool, contact, 0.006, 0.002))
        return plate, tools, presses

    try:
        plate, tools, presses = scene()
        carver.carve_many(presses)
        rev_plate, rev_tools, rev_presses = scene()
        carver.carve_many(rev_presses[::-1])
        alone_plates = []
        for k in range(len(_TOOLS)):
            one_plate, one_tools, one_presses = scene()
            carver.carve(*one_presses[k])
            alone = _maps(gl, one_tools[k])
            assert (alone[0] < DENTED).sum() > 10  # the tool takes a dent
            for got in (_maps(gl, tools[k]), _maps(gl, rev_tools[k])):
                assert np.array_equal(got[0], alone[0]) and np.array_equal(got[1], alone[1]), k
            alone_plates.append(heights(gl, one_plate))
        expected = np.minimum.reduce(alone_plates)
        assert np.array_equal(heights(gl, plate), expected)
        assert np.array_equal(heights(gl, rev_plate), expected)
    finally:
        carver.release()
        bodies.release()


def test_overlapping_hits_take_the_deeper_of_each_alone(gl):
    bodies = Bodies(gl)
    carver = Carver(gl)
    try:
        spots, depths = [(0.0, 0.0), (0.03, 0.01), (-0.02, 0.02)], [0.006, 0.004, 0.009]
        plate, balls = _scene(bodies, 3)
        carver.carve_many(_presses(plate, balls, spots, depths))
        got = heights(gl, plate)
        alone = []
        for spot, depth in zip(spots, depths, strict=True):
            fresh, (ball,) = _scene(bodies, 1)
            carver.carve(*_presses(fresh, [ball], [spot], [depth])[0])
            alone.append(heights(gl, fresh))
        expected = np.minimum.reduce(alone)
        # The footprints do overlap: somewhere two hits dent the same texel.
        assert ((np.stack(alone) < DENTED).sum(axis=0) >= 2).sum() > 50
        assert np.array_equal(got, expected)
    finally:
        carver.release()
        bodies.release()


def test_a_body_can_be_target_and_tool_in_one_batch(gl):
    """Ball 1 presses the plate (it is a tool and takes a dent too) while ball 2 presses ball 1
    from above (ball 1 is a target): ball 1 ends with the deeper of the two dents each leaves
    on it alone, on the same start."""
    bodies = Bodies(gl)
    carver = Carver(gl)
    r = 0.04

    def scene():
        plate, (one, two) = _scene(bodies, 2, r)
        one.model = translation((0.0, r, 0.0))
        two.model = translation((0.0, 3 * r, 0.0))
        on_plate = (plate, one, ContactFrame(np.zeros(3), DOWN), 0.005, 0.003)
        on_ball = (one, two, ContactFrame(np.array([0.0, 2 * r, 0.0]), DOWN), 0.004, 0.0)
        return plate, one, on_plate, on_ball

    try:
        plate, one, on_plate, on_ball = scene()
        carver.carve_many([on_plate, on_ball])
        got_plate, got_one = heights(gl, plate), heights(gl, one)
        alone = []
        for pick in (0, 1):
            fresh_plate, fresh_one, *presses = scene()
            carver.carve(*presses[pick])
            alone.append((heights(gl, fresh_plate), heights(gl, fresh_one)))
        assert np.array_equal(got_plate, alone[0][0])  # only the first press dents the plate
        assert np.array_equal(got_one, np.minimum(alone[0][1], alone[1][1]))
        # Both of ball 1's dents are there: one at its bottom, one at its top.
        assert (alone[0][1] < DENTED).sum() > 5 and (alone[1][1] < DENTED).sum() > 5
        assert not np.array_equal(got_one, alone[0][1]) and not np.array_equal(got_one, alone[1][1])
    finally:
        carver.release()
        bodies.release()


def test_press_many_in_the_public_api(gl):
    """press_many checks every press before any GPU work, says which could meet, and dents as
    the presses one by one would where they do not overlap."""
    from dentdemo.errors import ArgumentError

    ctx = gl.ctx
    make = dentdemo.DentableSurface
    plates = [make(ctx, dentdemo.shape_mesh(dentdemo.Plate(1.0)), 256) for _ in range(2)]
    balls = [make(ctx, dentdemo.shape_mesh(dentdemo.Sphere(0.04)), 64) for _ in range(4)]
    carver = dentdemo.Carver(ctx)
    try:
        for ball, x in zip(balls, (-0.2, 0.2, -0.2, 0.2), strict=True):
            ball.model = translation((x, 0.04, 0.0))
        down, up = (0, -1, 0), (0, 1, 0)
        presses = [
            (plates[0], balls[0], dentdemo.Contact((-0.2, 0, 0), down), 0.005),
            (plates[0], balls[1], dentdemo.Contact((0.2, 0, 0), up), 0.005, 0.001),  # leaves
        ]
        with pytest.raises(ArgumentError, match=r"presses\[1\].*depth"):
            carver.press_many([presses[0], (plates[0], balls[1], presses[0][2], -1.0)])
        with pytest.raises(ArgumentError, match=r"presses\[0\] must be"):
            carver.press_many([(plates[0], balls[0])])
        assert not plates[0].heights().any()  # nothing was pressed by the refused calls
        assert carver.press_many(presses) == [True, False]
        assert carver.press(plates[1], balls[2], dentdemo.Contact((-0.2, 0, 0), down), 0.005)
        assert np.array_equal(plates[0].heights(), plates[1].heights())
        assert np.array_equal(balls[0].heights(), balls[2].heights())
        assert not balls[1].heights().any()
    finally:
        for thing in (carver, *balls, *plates):
            thing.release()


def test_a_target_that_hides_part_of_itself_dents_in_a_batch_as_alone(gl):
    """A target that is not convex (a ring about +Y: pass 2 draws its address map, and pass 4
    reads it, CONVEX 0) pressed outwards into its inner equator by four balls in its hole, 97
    degrees apart: the batch, in either order, gives the heights and normals of the four
    presses made one by one (the batches above press convex targets only)."""
    ctx = gl.ctx
    ring = trimesh.creation.torus(0.1, 0.04, major_sections=96, minor_sections=48)
    ring.apply_transform(trimesh.transformations.rotation_matrix(-math.pi / 2, (1, 0, 0)))
    radius = 0.015
    presses = []
    for k in range(4):
        a = math.radians(97 * k)
        direction = np.array([math.cos(a), 0.0, math.sin(a)])
        presses.append((0.06 * direction, direction))  # the inner equator, pressed outwards
    made: list = []

    def pressed(order: list[int], batch: bool) -> tuple[np.ndarray, np.ndarray]:
        target = dentdemo.DentableSurface(ctx, ring, 512, max_dent_depth=0.01)
        carver = dentdemo.Carver(ctx)
        made.extend([target, carver])
        hits = []
        for k in order:
            point, direction = presses[k]
            ball = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Sphere(radius)), 64)
            made.append(ball)
            ball.model = translation(point - direction * radius)
            hits.append((target, ball, dentdemo.Contact(point, direction), 0.003))
        drawn: list[str] = []
        inner = carver._live()
        passes = inner._camera_passes

        def recorded(name, *rest, passes=passes):  # noqa: ANN001, ANN002, ANN202
            drawn.append(name)
            passes(name, *rest)

        inner._camera_passes = recorded
        if batch:
            assert carver.press_many(hits) == [True] * len(hits)
        else:
            assert all(carver.press(*hit) for hit in hits)
        assert "address" in drawn  # the ring is not convex: pass 2 drew
        return target.heights(), gl.read(target.normal)

    try:
        h_alone, n_alone = pressed([0, 1, 2, 3], batch=False)
        assert (h_alone < DENTED).sum() > 400
        for order in ([0, 1, 2, 3], [3, 2, 1, 0]):
            h, n = pressed(order, batch=True)
            assert np.array_equal(h, h_alone)
            assert np.array_equal(n, n_alone)
    finally:
        for thing in made:
            thing.release()


def _sphere_press(bodies, kind: str, degrees: float):
    """A ball into a plate, tilted `degrees` (both bodies dented), or a ball into a ball whose
    contact lies `degrees` round from the press direction (towards the target's silhouette);
    "capsule-...": a capsule (radius 4 cm, 6 cm between its ends) as the ball, lying tilted so
    that a hemisphere presses ("capsule-plate") or its side ("capsule-side")."""
    import math

    from surface_helpers import rotation

    r = 0.04
    t = math.radians(degrees)
    if kind.startswith("capsule"):
        tool = bodies.make(press_mesh(Capsule(r, 0.06), 2), 256)
        target = bodies.make(press_mesh(Plate(0.5), 2), 512)
        direction = np.array([math.sin(t), -math.cos(t), 0.0])
        if kind == "capsule-plate":  # its axis 30 degrees off vertical: the lower hemisphere
            centre = np.array([0.0, r + 0.03 * math.cos(math.radians(30)), 0.0])
            pose = rotation((1, 0, 0), 90 - 30)
            tool.model = translation(centre) @ pose
        else:  # its axis level: the straight side touches along a line
            tool.model = translation((0.0, r, 0.0)) @ rotation((0, 1, 0), 25)
        return target, tool, ContactFrame(np.zeros(3), direction), 0.006, 0.002
    tool = bodies.make(press_mesh(Sphere(r), 2), 256)
    if kind == "plate":
        target = bodies.make(press_mesh(Plate(0.5), 2), 512)
        direction = np.array([math.sin(t), -math.cos(t), 0.0])
        tool.model = translation((0.0, r, 0.0)) @ rotation((1, 2, 3), 37)
        return target, tool, ContactFrame(np.zeros(3), direction), 0.006, 0.002
    target = bodies.make(press_mesh(Sphere(0.06), 2), 512)
    normal = np.array([math.sin(t), math.cos(t), 0.0])  # outward at the contact
    point = 0.06 * normal
    tool.model = translation(point + r * normal) @ rotation((0, 1, 1), 20)
    return target, tool, ContactFrame(point, -np.array([0.0, 1.0, 0.0])), 0.004, 0.002


@pytest.mark.parametrize(
    "kind,degrees",
    [
        ("plate", 0),
        ("plate", 25),
        ("plate", 45),
        ("ball", 0),
        ("ball", 50),
        ("capsule-plate", 0),
        ("capsule-plate", 30),
        ("capsule-side", 0),
        ("capsule-side", 20),
    ],
)
@pytest.mark.slow
def test_spheres_drawn_as_quads_carve_as_their_facets_did(gl, bodies, kind, degrees):
    """Passes 2 and 3 draw a built-in sphere or capsule as one quad over its extent and find its
    exact surface per pixel; the dents match those of the solid drawn as its facets (which found
    the same exact surface within each facet's pixels), to 1e-6 m, on both bodies."""
    results = []
    for quads in (False, True):
        carver = Carver(gl, _switches=_Switches(swept_quads=quads))
        try:
            target, tool, contact, depth, tool_depth = _sphere_press(bodies, kind, degrees)
            assert carver.carve(target, tool, contact, depth, tool_depth)
            results.append((heights(gl, target), heights(gl, tool)))
        finally:
            carver.release()
    for facets, quad in zip(*results, strict=True):
        assert (quad < DENTED).sum() > 20
        assert float(np.abs(facets - quad).max()) <= 1e-6


@pytest.mark.parametrize("shape", ["sphere", "capsule-end", "capsule-side"])
def test_a_dented_sphere_drawn_as_a_quad_reads_its_own_heights(gl, bodies, shape):
    """The quad path finds a sphere's (capsule's) texel from the point itself (sphere_uv.glsl,
    capsule_uv.glsl), the facet path from the facet's uv: with heights already on the tool (a
    smooth pattern, up to 1 mm), the two give the same dent in the plate where they pick the
    same texel, and never differ by more than the pattern changes over one texel."""
    size = 256
    u = (np.arange(size) + 0.5) / size
    pattern = -0.0005 * (1 + np.sin(6 * np.pi * u)[None, :] * np.sin(4 * np.pi * u)[:, None])
    step = 0.0005 * 6 * np.pi / size * 1.5  # the pattern's largest change over a texel, and some
    results = []
    for quads in (False, True):
        carver = Carver(gl, _switches=_Switches(swept_quads=quads))
        try:
            target = bodies.make(press_mesh(Plate(0.5), 2), 512)
            solid = Sphere(0.04) if shape == "sphere" else Capsule(0.04, 0.06)
            tool = bodies.make(press_mesh(solid, 2), size, initial_height=pattern)
            if shape == "capsule-end":  # axis 30 degrees off vertical: a hemisphere presses
                tool.model = translation((0.0, 0.04 + 0.03 * math.cos(math.radians(30)), 0.0))
                tool.model = tool.model @ rotation((1, 0, 0), 60)
            elif shape == "capsule-side":  # axis level, turned: the straight side presses
                tool.model = translation((0.0, 0.04, 0.0)) @ rotation((0, 1, 0), 25)
            else:
                tool.model = translation((0.0, 0.04, 0.0))
            carver.carve(target, tool, ContactFrame(np.zeros(3), DOWN), 0.006)
            results.append(heights(gl, target))
        finally:
            carver.release()
    diff = np.abs(results[0] - results[1])
    dented = results[1] < DENTED
    assert dented.sum() > 100
    assert float(np.median(diff[dented])) <= 1e-6
    assert float(diff.max()) <= step


_SQRT_HALF = math.sqrt(0.5)
#: A built-in target, where it is pressed (world) and the outward normal there, the press's tilt
#: from square-on (degrees) and the tool: "ball" (a 3 cm ball) or "slab" (a box's face).
_CONVEX_PRESSES = {
    "plate square-on": (Plate(0.5), (0.05, 0.0, -0.02), (0, 1, 0), 0, "ball"),
    "plate at 35 degrees": (Plate(0.5), (0.0, 0.0, 0.0), (0, 1, 0), 35, "ball"),
    "plate at 65 degrees": (Plate(0.5), (0.0, 0.0, 0.0), (0, 1, 0), 65, "ball"),
    "box edge": (Box((0.2, 0.2, 0.2)), (0.1, 0.1, 0.0), (_SQRT_HALF, _SQRT_HALF, 0), 0, "ball"),
    "box corner": (Box((0.2, 0.2, 0.2)), (0.1, 0.1, 0.1), (1, 1, 1), 10, "ball"),
    "ball on a slab": (Sphere(0.04), (0.0, 0.04, 0.0), (0, 1, 0), 40, "slab"),
    "capsule where cap meets side": (Capsule(0.05, 0.2), (0.05, 0.0, 0.1), (1, 0, 0), 30, "ball"),
    "cylinder rim": (Cylinder(0.1, 0.2), (0.1, 0.0, 0.1), (_SQRT_HALF, 0, _SQRT_HALF), 0, "ball"),
}


@pytest.mark.parametrize("case", list(_CONVEX_PRESSES))
def test_a_convex_target_needs_no_address_map(gl, case):
    """A built-in target hides none of its own surface (docs/carve.md, "Pass 2"): carving it
    without pass 2 gives the same bits as with it, on both bodies, at edges, corners, caps and
    steep tilts; and pass 2 is not drawn for it."""
    shape, point, normal, degrees, tool_kind = _CONVEX_PRESSES[case]
    bodies = Bodies(gl)
    try:
        results = []
        for every in (True, False):
            carver = Carver(gl, CarverOptions(address_every_target=every))
            drawn: list[str] = []
            passes = carver._camera_passes

            def recorded(name, *rest, passes=passes, drawn=drawn):  # noqa: ANN001, ANN002, ANN202
                drawn.append(name)
                passes(name, *rest)

            carver._camera_passes = recorded  # type: ignore[method-assign]
            target = bodies.make(press_mesh(shape, 2), 256)
            make = ball_on if tool_kind == "ball" else slab_on
            tool, n = make(bodies, point, normal)
            contact = ContactFrame(np.asarray(point, dtype=np.float64), tilt(n, degrees))
            assert len(carver.carve(target, tool, contact, 0.004, 0.002)) == 2
            assert drawn == (["peel", "address"] if every else ["peel"])
            results.append([_maps(gl, body) for body in (target, tool)])
            carver.release()
        for (h_all, n_all), (h_convex, n_convex) in zip(*results, strict=True):
            assert (h_all < DENTED).sum() > 10  # each body took a dent
            assert np.array_equal(h_all, h_convex)
            assert np.array_equal(n_all, n_convex)
    finally:
        bodies.release()


def test_a_batch_binds_each_map_once_a_pass(gl, monkeypatch):
    """Passes 4 and 5 of a batch draw every variant of a map (its chart triangles, then the
    gutter around them) before moving to the next map: each dented map's height and normal
    framebuffers are bound exactly once. Balls turned 45 degrees about z are pressed on a cube
    edge of their atlas, so every ball job draws both variants (checked)."""
    import moderngl

    bodies = Bodies(gl)
    carver = Carver(gl)
    try:
        plate, balls = _scene(bodies, 3)
        presses = _presses(plate, balls, SPOTS[:3], [0.004] * 3)
        for ball, (x, z) in zip(balls, SPOTS[:3], strict=True):
            ball.model = translation((x, 0.04, z)) @ rotation((0, 0, 1), 45.0)
        planned = [carver.plan(*press) for press in presses]
        ball_jobs = [job for hit in planned for job in hit if job.target is not plate]
        assert len(ball_jobs) == 3
        assert all(len(job.camera.target_gutter) > 0 for job in ball_jobs)
        bound: list[moderngl.Framebuffer] = []
        use = moderngl.Framebuffer.use

        def counting(fbo):
            bound.append(fbo)
            return use(fbo)

        monkeypatch.setattr(moderngl.Framebuffer, "use", counting)
        carver.carve_hits(planned)
        monkeypatch.undo()
        for body in (plate, *balls):
            for fbo in (body.maps.height_fbo, body.maps.normal_fbo):
                assert sum(b is fbo for b in bound) == 1
        assert (heights(gl, balls[0]) < DENTED).sum() > 10  # the balls were dented
    finally:
        carver.release()
        bodies.release()


def test_a_batch_hands_its_last_pass_to_the_rasteriser_before_returning(gl, monkeypatch):
    """The last GL call a batch makes is glFlush, after the last draw of pass 5 (and another
    follows the camera passes): a software rasteriser then draws the normals while the host goes
    on with its CPU work, instead of when the host's next call that waits starts them. Checked
    from the calls themselves: the draws (VertexArray.render) and flushes in order."""
    import moderngl

    from dentdemo.carve import carver as carver_module

    bodies = Bodies(gl)
    carver = Carver(gl)
    try:
        plate, balls = _scene(bodies, 2)
        planned = [carver.plan(*p) for p in _presses(plate, balls, SPOTS[:2], [0.004] * 2)]
        calls: list[str] = []
        render = moderngl.VertexArray.render
        flush = carver_module.flush

        def drawing(vao, *args, **kwargs):
            calls.append("draw")
            return render(vao, *args, **kwargs)

        def flushing() -> None:
            calls.append("flush")
            flush()

        monkeypatch.setattr(moderngl.VertexArray, "render", drawing)
        monkeypatch.setattr(carver_module, "flush", flushing)
        carver.carve_hits(planned)
        monkeypatch.undo()
        assert calls.count("flush") == 2 and calls[-1] == "flush"
        assert calls[calls.index("flush") - 1] == "draw" and calls[-2] == "draw"
        assert (heights(gl, plate) < DENTED).sum() > 10  # the plate was dented
    finally:
        carver.release()
        bodies.release()


def test_the_hosts_work_runs_once_while_the_gathers_are_drawn(gl, monkeypatch):
    """`meanwhile` runs exactly once a call: after the gathers' last draw has been handed to the
    rasteriser (a glFlush after it) and before the first normal rebuild, also when the batch is
    split over the atlas (once, in the first part) and when no hit has a direction (then alone)."""
    from dentdemo.carve import carver as carver_module

    bodies = Bodies(gl)
    carver = Carver(gl, CarverOptions(max_resolution=20))  # an atlas of 64 x 32: 3 tiles a part
    try:
        plate, balls = _scene(bodies, len(SPOTS))
        presses = _presses(plate, balls, SPOTS, [0.004] * len(SPOTS))
        calls: list[str] = []
        for name in ("_gather_passes", "_normal_passes"):
            method = getattr(Carver, name)

            def marked(self, *args, _method=method, _name=name):
                calls.append(_name + " begins")
                _method(self, *args)
                calls.append(_name + " ends")

            monkeypatch.setattr(Carver, name, marked)
        flush = carver_module.flush
        monkeypatch.setattr(carver_module, "flush", lambda: calls.append("flush") or flush())
        jobs = carver.carve_many(presses, meanwhile=lambda: calls.append("meanwhile"))
        assert len(jobs) == 12 and calls.count("_gather_passes begins") > 1  # parts
        assert calls.count("meanwhile") == 1
        at = calls.index("meanwhile")
        assert calls[at - 2 : at + 2] == [
            "_gather_passes ends",
            "flush",
            "meanwhile",
            "_normal_passes begins",
        ]
        assert calls.index("_normal_passes begins") > at  # no rebuild before it
        second = calls.index("_gather_passes begins", calls.index("_gather_passes ends"))
        assert at < second  # in the first part
        calls.clear()
        far = translation((5.0, 0.04, 5.0))  # a ball nowhere near the plate: no direction
        balls[0].model = far
        assert carver.carve_many([presses[0]], meanwhile=lambda: calls.append("meanwhile")) == []
        assert calls == ["meanwhile"]
    finally:
        carver.release()
        bodies.release()


def _posed_spheres(mesh, model, origin, axes, clusters: bool):
    """The triangles' (or clusters') bounding spheres in camera coordinates, from their
    definition: world = model (local), camera = axes (world - origin), radii scaled by the
    pose's uniform scale."""
    if clusters:
        centre, radius, _ = mesh.clusters()
    else:
        centre, radius = mesh.triangle_spheres()
    world = centre @ model[:3, :3].T + model[:3, 3]
    scale = np.linalg.norm(model[:3, 0])
    return (world - origin) @ axes.T, radius * scale


def _meets_box(centre, radius, rect, slab) -> np.ndarray:
    x, y, s = centre.T
    return (
        (x + radius >= rect.x0)
        & (x - radius <= rect.x1)
        & (y + radius >= rect.y0)
        & (y - radius <= rect.y1)
        & (s + radius >= slab[0])
        & (s - radius <= slab[1])
    )


@pytest.mark.parametrize("exact", [True, False], ids=["triangles", "clusters"])
@pytest.mark.parametrize("seed", range(3))
def test_a_batchs_triangle_lists_are_each_querys_own(seed: int, exact: bool) -> None:
    """`meeting_many` over a batch of queries (five meshes, poses turned, scaled and mirrored,
    boxes of 5 mm to 40 cm, open-ended slabs) gives each query the triangles whose bounding
    sphere meets its box, worked out here over every triangle from the definition (with
    `exact` False: every triangle of each cluster whose sphere meets it), and the same as that
    query alone."""
    from dentdemo.carve.footprint import Projected, Rect, meeting_many

    rng = np.random.default_rng(seed)
    meshes = [
        press_mesh(Sphere(0.05), 1),
        press_mesh(Capsule(0.03, 0.1), 1),
        press_mesh(Box((0.2, 0.1, 0.3)), 2),
        press_mesh(Plate(1.0), 2),
        press_mesh(Cylinder(0.05, 0.2), 1),
    ]
    queries, expected = [], []
    for k in range(14):
        mesh = meshes[k % len(meshes)]
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        model = np.eye(4)
        model[:3, :3] = q * rng.uniform(0.5, 2.0)  # a rotation or a mirror, times a scale
        model[:3, 3] = rng.normal(scale=0.2, size=3)
        axes, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        axes = axes.T  # rows: right, up, forward
        origin = model[:3, 3] + rng.normal(scale=0.05, size=3)
        projected = Projected(mesh, model, origin, axes)
        cx, cy = rng.normal(scale=0.05, size=2)
        hx, hy = rng.uniform(0.005, 0.2, size=2)
        rect = Rect(cx - hx, cx + hx, cy - hy, cy + hy)
        lo = rng.uniform(-0.2, 0.05)
        slab = (lo, np.inf) if k % 4 == 3 else (lo, lo + rng.uniform(0.001, 0.1))
        queries.append((projected, rect, slab))
        centre, radius = _posed_spheres(mesh, model, origin, axes, clusters=not exact)
        near = _meets_box(centre, radius, rect, slab)
        if exact:
            expected.append(np.flatnonzero(near))
        else:
            members = mesh.clusters()[2][near].ravel()
            expected.append(np.sort(members[members >= 0]))
    found = meeting_many(queries, exact)
    assert sum(len(e) for e in expected) > 50  # the boxes meet triangles
    assert sum(len(e) == 0 for e in expected) >= 1  # and some meet none
    for query, got, want in zip(queries, found, expected, strict=True):
        assert np.array_equal(np.sort(got), want)
        (alone,) = meeting_many([query], exact)
        assert np.array_equal(alone, got)


def test_plan_many_keeps_each_presses_directions(gl) -> None:
    """`plan_many` of a batch that mixes good presses with a contact direction holding NaN, a
    zero direction, a press with no tool depth (one direction), a press whose ball was moved a
    metre away (none), a negative target depth (the tool's direction only) and a press given
    twice: each press gets the directions its own geometry gives, in order, with the cameras
    it gets when planned alone."""
    bodies = Bodies(gl)
    carver = Carver(gl)
    try:
        plate, balls = _scene(bodies, 4)
        good = _presses(plate, balls, SPOTS[:4], [0.004, 0.005, 0.006, 0.003])
        balls[3].model = translation((5.0, 3.0, 5.0))  # good[3]'s ball, far from the plate
        origin = np.zeros(3)
        presses = [
            good[0],
            (plate, balls[1], ContactFrame(origin, np.array([np.nan, -1.0, 0.0])), 0.004, 0.001),
            good[1],
            (plate, balls[1], ContactFrame(origin, np.zeros(3)), 0.004, 0.001),
            (*good[2][:4], 0.0),
            good[3],
            (*good[0][:3], -0.004, 0.001),
            good[0],
        ]
        planned = carver.plan_many(presses)
        assert [len(jobs) for jobs in planned] == [2, 0, 2, 0, 1, 0, 1, 2]
        assert planned[4][0].target is plate and planned[6][0].target is balls[0]
        for jobs, press in zip(planned, presses, strict=True):
            alone = carver.plan(*press)
            assert len(jobs) == len(alone)
            for a, b in zip(jobs, alone, strict=True):
                assert a.target is b.target and a.tool is b.tool
                assert np.array_equal(a.camera.eye, b.camera.eye)
                assert a.camera.resolution == b.camera.resolution
                assert np.array_equal(a.camera.target_texels, b.camera.target_texels)
                assert np.array_equal(a.camera.tool_view, b.camera.tool_view)
    finally:
        carver.release()
        bodies.release()


def test_a_carver_is_configured_once_by_frozen_options(gl):
    """What a Carver does is fixed when it is made: none of the eight flags it had is an
    attribute to set, its options cannot be changed or replaced, and a Press names its fields
    and is still a 5-tuple."""
    import dataclasses

    from dentdemo.carve.carver import Press

    carver = Carver(gl, CarverOptions(keep_host_state=False, max_resolution=64))
    try:
        flags = {
            "swept_quads",
            "loose_camera",
            "rect_texels_per_triangle",
            "address_every_target",
            "exact_lists",
            "keep_host_state",
            "undo_log",
            "pass_timer",
        }
        assert not flags & {name for name in vars(carver) if not name.startswith("_")}
        with pytest.raises(dataclasses.FrozenInstanceError):
            carver.options.keep_host_state = True  # type: ignore[misc]
        with pytest.raises(AttributeError):
            carver.options = CarverOptions()  # type: ignore[misc]
        assert carver.options.keep_host_state is False and carver.max_resolution == 64
        # Its atlas: two 64-pixel cameras side by side, a pixel apart (129), to a power of two.
        assert carver.scratch.size == (256, 128)
    finally:
        carver.release()
    press = Press("target", "tool", "contact", 0.004)  # type: ignore[arg-type]
    assert press.depth == 0.004 and press.tool_depth == 0.0
    assert tuple(press) == ("target", "tool", "contact", 0.004, 0.0)


def _peel_atlas(gl, carver: Carver, presses) -> tuple[np.ndarray, int, int]:
    """Pass 3 of `presses` as one batch: the scratch atlas's tool-extent pixels (its bits), the
    jobs, and the draws of mesh tools (TILED or not)."""
    from dentdemo.gl.state import preserved

    (batch,) = carver.scratch.pack(carver.plan_many(presses))
    runs = carver._camera_runs("peel", list(enumerate(batch)), iter(range(len(batch), 99999)))
    meshes = sum(1 for run in runs if run.items[0][2] is not None)  # a triangle list
    with preserved(gl.ctx):
        carver._camera_stage(batch)
    return gl.read(carver.scratch.tool_depth).view(np.uint32), len(batch), meshes


@pytest.mark.parametrize("case", ["plate on balls", "tilted boxes"])
def test_an_instanced_mesh_peel_writes_what_its_own_viewport_did(gl, case):
    """Pass 3 of mesh tools drawn instanced, each job placed in its tile by the vertex stage and
    clipped to the tile's pixel edges (surface.vert TILED 1; the plate's lists differ from hit to
    hit: their union, each instance dropping the others' triangles) writes the same bits in
    every pixel of the atlas as a draw a job with its tile as the viewport."""
    bodies = Bodies(gl)
    try:
        plate = bodies.make(press_mesh(Plate(1.0), 2), 512)
        presses = []
        for k, (x, z) in enumerate(SPOTS * 2):
            x, z = x + 0.013 * k, z - 0.007 * k
            if case == "plate on balls":  # the ball dented by the plate: the plate is a tool
                tool = bodies.make(press_mesh(Sphere(0.04), 1), 128) if k == 0 else presses[0][1]
                posed = type(tool)(tool.gpu_mesh, tool.maps, translation((x, 0.04, z)))
                direction = DOWN
            else:
                tool = bodies.make(press_mesh(Box((0.05, 0.03, 0.04)), 2), 128)
                posed = tool
                posed.model = translation((x, 0.02, z)) @ rotation((0, 1, 0), 10.0 * k)
                direction = tilt(np.array([0.0, 1.0, 0.0]), 20.0)
            contact = ContactFrame(np.array([x, 0.0, z]), direction)
            presses.append((plate, posed, contact, 0.003, 0.002))
        found = []
        for tiled in (True, False):
            carver = Carver(gl, _switches=_Switches(tiled_peel=tiled))
            try:
                found.append(_peel_atlas(gl, carver, presses))
            finally:
                carver.release()
        (tiled_bits, jobs, tiled_draws), (own_bits, _, own_draws) = found
        assert jobs == 4 * len(SPOTS)
        # A mesh tool a hit (the plate on the ball), or two (each box's own, and the plate).
        assert own_draws == (jobs // 2 if case == "plate on balls" else jobs)
        assert tiled_draws < own_draws
        assert (tiled_bits[:, :, 1] != 0).sum() > 1000  # covered pixels
        assert np.array_equal(tiled_bits, own_bits)
    finally:
        bodies.release()
