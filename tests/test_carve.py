"""The carve against DESIGN.md's oracles: spherical cap, idempotence, monotonicity, bump-to-depth,
both bodies, tilted press, normals, seams, and no NaN ever."""

from __future__ import annotations

import math

import moderngl
import numpy as np
import pytest

from carve_helpers import cap, heights, plate_xz, release, setup
from dentdemo.app.press import cap_error, footprint_radius
from dentdemo.carve.camera import ContactFrame
from surface_helpers import cut_cap_errors


@pytest.mark.parametrize(
    "radius,depth,offset",
    [
        (0.05, 0.01, (0.0, 0.0)),
        (0.05, 0.002, (0.0, 0.0)),
        (0.1, 0.02, (0.0, 0.0)),
        (0.03, 0.005, (0.17, -0.23)),
        (0.08, 0.01, (-0.3113, 0.2071)),
    ],
)
def test_spherical_cap(gl, carver, radius, depth, offset):
    s = setup(gl, tool_size=(radius,), offset=offset)
    carver.carve(s.target, s.tool, s.contact, depth)
    h = heights(gl, s.target)
    stats = cap_error(h, 1.0, offset, radius, depth)
    texel = 1.0 / 512
    assert stats["rms_error_rel"] <= 0.02
    measured = footprint_radius(h, texel * texel)
    assert abs(measured - stats["footprint_radius_expected_m"]) <= 1.5 * texel
    assert stats["volume_m3"] == pytest.approx(stats["volume_expected_m3"], rel=0.03)
    # Nothing outside the footprint (plus a texel) changed.
    x, z = plate_xz(h.shape, 1.0)
    far = (x - offset[0]) ** 2 + (z - offset[1]) ** 2 > (
        stats["footprint_radius_expected_m"] + 2 * texel
    ) ** 2
    assert np.all(h[far] == 0.0)
    release(s)


def test_same_press_five_times_equals_once(gl, carver):
    s = setup(gl, offset=(0.1, 0.05))
    carver.carve(s.target, s.tool, s.contact, 0.008)
    once = heights(gl, s.target)
    for _ in range(4):
        carver.carve(s.target, s.tool, s.contact, 0.008)
    np.testing.assert_allclose(heights(gl, s.target), once, atol=1e-6, rtol=0)
    release(s)


def test_deeper_press_gives_deeper_cap(gl, carver):
    s = setup(gl)
    carver.carve(s.target, s.tool, s.contact, 0.004)
    shallow = heights(gl, s.target)
    carver.carve(s.target, s.tool, s.contact, 0.01)
    deep = heights(gl, s.target)
    assert np.all(deep <= shallow + 1e-7)  # dents only deepen
    assert cap_error(deep, 1.0, (0, 0), 0.05, 0.01)["rms_error_rel"] <= 0.02
    # A shallower press afterwards changes nothing.
    carver.carve(s.target, s.tool, s.contact, 0.003)
    np.testing.assert_allclose(heights(gl, s.target), deep, atol=1e-6, rtol=0)
    release(s)


def test_press_beside_a_dent_leaves_it_outside_the_overlap(gl, carver):
    s1 = setup(gl, offset=(0.0, 0.0))
    carver.carve(s1.target, s1.tool, s1.contact, 0.01)
    first = heights(gl, s1.target)
    # Second press 4 cm away on the same plate: footprints (3 cm radius each) overlap a little.
    s2 = setup(gl, offset=(0.04, 0.0))
    carver.carve(s1.target, s2.tool, s2.contact, 0.01)
    both = heights(gl, s1.target)
    second_alone = cap(both.shape, 1.0, (0.04, 0.0), 0.05, 0.01)
    outside = second_alone == 0.0
    np.testing.assert_array_equal(both[outside], first[outside])
    # Inside the overlap the result is the deeper of the two caps.
    expected = np.minimum(cap(both.shape, 1.0, (0, 0), 0.05, 0.01), second_alone)
    assert np.sqrt(np.mean((both - expected)[both < 0] ** 2)) < 0.02 * 0.01
    release(s1)
    release(s2)


def test_patterned_tool_leaves_its_mirrored_pattern(gl, carver):
    # A 10 cm cube whose height map carries stripes of +1 mm along u; its bottom face (chart -Y)
    # maps u to +x and v to +z, the plate v to -z: the print is the tool's pattern mirrored in v.
    size = 256
    u = (np.arange(size) + 0.5) / size
    v = (np.arange(size) + 0.5) / size
    pattern = np.where((np.floor(u * 24) % 2 == 0)[None, :] & (v[:, None] > 0.3), 0.001, 0.0)
    pattern = np.ascontiguousarray(np.broadcast_to(pattern, (size, size)), dtype=np.float32)
    s = setup(gl, tool="box", tool_size=(0.1,), tool_map_size=size, tool_height=pattern)
    depth = 0.002
    carver.carve(s.target, s.tool, s.contact, depth)
    h = heights(gl, s.target)
    mesh = s.tool.gpu_mesh.mesh
    x, z = plate_xz(h.shape, 1.0)
    inside = (np.abs(x) < 0.049) & (np.abs(z) < 0.049)
    expected = np.zeros_like(h)
    # Tool uv of the bottom-face point above each plate texel.
    from dentdemo.mesh.primitives import _cell

    u0, v0, du, dv = _cell(3)
    tu = u0 + (x[inside] / 0.1 + 0.5) * du
    tv = v0 + (z[inside] / 0.1 + 0.5) * dv
    # The tool's surface is its height map bilinear between texel centres (as drawn): a stripe's
    # edge ramps over one tool texel.
    fu, fv = tu * size - 0.5, tv * size - 0.5
    i0, j0 = np.floor(fu).astype(int), np.floor(fv).astype(int)
    wu, wv = fu - i0, fv - j0

    def at(j, i):
        return pattern[np.clip(j, 0, size - 1), np.clip(i, 0, size - 1)]

    bump = (1 - wv) * ((1 - wu) * at(j0, i0) + wu * at(j0, i0 + 1)) + wv * (
        (1 - wu) * at(j0 + 1, i0) + wu * at(j0 + 1, i0 + 1)
    )
    # The tool's bumps stand 1 mm proud of its face: where a bump is, the plate goes 1 mm deeper.
    expected[inside] = -(depth + bump)
    assert mesh.name == "box"
    assert np.mean(np.abs(h[inside] - expected[inside]) < 1e-5) > 0.97
    assert np.all(h[~inside & ((np.abs(x) > 0.052) | (np.abs(z) > 0.052))] == 0.0)
    # Both stripe depths are present in about the pattern's proportions: a print, not a flat dent
    # (the rest on the ramps between them).
    deep = np.isclose(h[inside], -0.003, atol=1e-5).mean()
    shallow = np.isclose(h[inside], -0.002, atol=1e-5).mean()
    assert deep > 0.25 and shallow > 0.25 and deep + shallow > 0.85
    release(s)


def test_both_bodies_dented_each_by_its_own_depth(gl, carver):
    s = setup(gl, tool_map_size=256)
    carver.carve(s.target, s.tool, s.contact, 0.006, tool_depth=0.002)
    target = heights(gl, s.target)
    tool = heights(gl, s.tool)
    assert -target.min() == pytest.approx(0.006, rel=0.01)
    assert -tool.min() == pytest.approx(0.002, rel=0.05)
    # The tool's dent is a flat spot of radius sqrt(2 R d - d^2) on the ball: it sits on the ball's
    # bottom chart and is about as wide as that cap.
    dented = (tool < -1e-6).sum()
    tu, tv = s.tool.maps.texel_metres
    cap_area = math.pi * (2 * 0.05 * 0.002 - 0.002**2)
    assert dented * tu * tv == pytest.approx(cap_area, rel=0.35)
    # Without tool depth the tool stays pristine.
    s2 = setup(gl)
    carver.carve(s2.target, s2.tool, s2.contact, 0.006)
    assert np.all(heights(gl, s2.tool) == 0.0)
    release(s)
    release(s2)


def test_tilted_press_leaves_the_tilted_footprint(gl, carver):
    # What a press means (docs/carve.md): the ball moves `depth` along D, and each plate point
    # inside the solid it sweeps moves down along the plate's normal until it leaves that solid
    # (test_carve_oblique's oracle: the lowest point of the spheres along the sweep).
    from test_carve_oblique import swept_ball_depth

    theta = math.radians(30)
    direction = np.array([math.sin(theta), -math.cos(theta), 0.0])
    radius, depth = 0.05, 0.01
    s = setup(gl, direction=direction)
    carver.carve(s.target, s.tool, s.contact, depth)
    h = heights(gl, s.target)
    x, z = plate_xz(h.shape, 1.0)
    start = np.array([0.0, radius, 0.0])  # touching the plate at the origin
    near = (np.abs(x) < 2 * radius) & (np.abs(z) < 2 * radius)
    expected = np.zeros_like(h, dtype=np.float64)
    expected[near] = -swept_ball_depth(x[near], z[near], start, start + direction * depth, radius)
    region = (expected < 0) | (h < 0)
    rms = np.sqrt(np.mean((h[region] - expected[region]) ** 2))
    assert rms <= 0.02 * depth
    # The footprint has the analytic one's extents and is shifted the same way along the tilt.
    texel = 1.0 / 512
    dented, wanted = h < -1e-6, expected < -1e-6
    assert abs(np.ptp(x[dented]) - np.ptp(x[wanted])) <= 1.5 * texel
    assert abs(np.ptp(z[dented]) - np.ptp(z[wanted])) <= 1.5 * texel
    assert abs(x[dented].mean() - x[wanted].mean()) <= 0.5 * texel
    assert x[wanted].mean() > 2 * texel  # the tilt really moves the footprint
    release(s)


def test_rebuilt_normals_follow_the_cap_gradient(gl, carver):
    radius, depth = 0.05, 0.01
    s = setup(gl)
    carver.carve(s.target, s.tool, s.contact, depth)
    normal = gl.read(s.target.maps.normal)[:, :, :3].astype(np.float64) / 255.0 * 2 - 1
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    x, z = plate_xz(normal.shape[:2], 1.0)
    r = np.hypot(x, z)
    footprint = math.sqrt(2 * radius * depth - depth**2)
    inner = r < 0.8 * footprint  # away from the rim's kink
    # Analytic: h = -d + R - sqrt(R^2 - r^2); dh/dx = x / sqrt(R^2 - r^2). Tangent space (T=+x,
    # B=-z, N=+y): n = normalize(-dh/dx, -dh/d(-z), 1) = normalize(-dh/dx, dh/dz, 1).
    root = np.sqrt(radius**2 - r[inner] ** 2)
    analytic = np.stack([-x[inner] / root, z[inner] / root, np.ones(inner.sum())], -1)
    analytic /= np.linalg.norm(analytic, axis=-1, keepdims=True)
    angle = np.degrees(np.arccos(np.clip((analytic * normal[inner]).sum(-1), -1, 1)))
    assert angle.mean() < 3.0
    # Pristine area stays flat.
    flat = normal[r > footprint + 0.01]
    assert np.all(flat[:, 2] > 0.999)
    release(s)


def test_dent_across_sphere_chart_seam_is_continuous(gl, carver):
    # A small ball pressed onto a big sphere exactly at the edge between its +X and +Y charts.
    s = setup(gl, target="sphere", target_size=(0.3,), tool_size=(0.04,), map_size=512)
    n = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    point = 0.3 * n
    s.tool.model[:3, 3] = point + 0.04 * n
    depth = 0.006
    carver.carve(s.target, s.tool, ContactFrame(point, -n), depth)
    h = heights(gl, s.target)
    mesh = s.target.gpu_mesh.mesh
    # Sample the dented surface through the mesh: each vertex's height by its own uv.
    size = h.shape[0]
    uv = mesh.uvs.astype(np.float64)
    texel = np.clip((uv * size).astype(int), 0, size - 1)
    vh = h[texel[:, 1], texel[:, 0]]
    pos = mesh.positions.astype(np.float64)
    dist = np.linalg.norm(pos - point, axis=1)
    # Analytic depth at surface distance s from the contact, for a sphere of 4 cm pressed 6 mm
    # (the target's curvature changes this by < 5 %): both charts must follow one profile.
    near = dist < 0.012
    charts = (uv[near, 0] > 1 / 3).astype(int) + 2 * (uv[near, 1] > 0.5)
    assert len(np.unique(charts)) == 2, "the press must straddle two charts"
    expected = -(depth - (0.04 - np.sqrt(np.maximum(0.04**2 - dist[near] ** 2, 0))))
    err = vh[near] - expected
    assert np.abs(err).max() < 0.15 * depth
    # Across the seam: vertices at the same place on either side agree.
    dup = {}
    for i in np.where(near)[0]:
        dup.setdefault(tuple(np.round(pos[i], 6)), []).append(vh[i])
    pairs = [v for v in dup.values() if len(v) > 1]
    assert pairs, "expected duplicated seam vertices inside the dent"
    assert max(abs(v[0] - v[1]) for v in pairs) < 0.05 * depth
    # Normals at the seam have no crack: seam texels on both charts tilt the same amount.
    nm = gl.read(s.target.maps.normal)[:, :, :3].astype(np.float64) / 255 * 2 - 1
    tilt = np.degrees(np.arccos(np.clip(nm[..., 2] / np.linalg.norm(nm, axis=-1), -1, 1)))
    seam = [i for i in np.where(near)[0] if len(dup[tuple(np.round(pos[i], 6))]) > 1]
    t = tilt[texel[seam, 1], texel[seam, 0]]
    groups = {}
    for i, tv in zip(seam, t, strict=True):
        groups.setdefault(tuple(np.round(pos[i], 6)), []).append(tv)
    diffs = [abs(g[0] - g[1]) for g in groups.values() if len(g) == 2]
    assert np.median(diffs) < 4.0
    release(s)


@pytest.mark.slow
def test_no_nan_after_random_and_degenerate_presses(gl, carver):
    rng = np.random.default_rng(7)
    s = setup(gl, map_size=256, tool_map_size=128, max_dent_depth=0.02)
    big = setup(gl, map_size=128, tool_size=(2.0,), tool_map_size=64, max_dent_depth=0.02)
    for i in range(1000):
        kind = i % 10
        offset = rng.uniform(-0.6, 0.6, 2)
        point = np.array([offset[0], 0.0, offset[1]])
        direction = np.array([rng.uniform(-0.5, 0.5), -1.0, rng.uniform(-0.5, 0.5)])
        depth = float(rng.uniform(0, 0.01))
        tool = s.tool
        if kind == 0:
            depth = 0.0
        elif kind == 1:
            point = np.array([5.0, 3.0, 5.0])  # tool far outside the target
        elif kind == 2:
            depth = 5.0  # far beyond max_dent_depth
        elif kind == 3:
            tool = big.tool  # a tool larger than the target
        elif kind == 4:
            direction = np.array([1.0, 0.0, 0.0])  # grazing
        elif kind == 5:
            depth = float("nan")
        elif kind == 6:
            direction = np.array([0.0, 0.0, 0.0])
        r = tool.radius()
        tool.model[:3, 3] = point + np.array([0.0, r, 0.0])
        carver.carve(s.target, tool, ContactFrame(point, direction), depth, tool_depth=depth / 2)
    h = heights(gl, s.target)
    t = heights(gl, s.tool)
    for arr in (h, t):
        assert np.isfinite(arr).all()
        assert arr.max() <= 0.0 and arr.min() >= -0.02 - 1e-7
    nm = gl.read(s.target.maps.normal)
    assert nm.dtype == np.uint8 and (nm[..., 2] >= 127).all()  # normals face out
    assert (h < 0).mean() > 0.1
    release(s)
    release(big)


@pytest.mark.slow
def test_carving_reads_nothing_back(gl, carver, monkeypatch):
    s = setup(gl, map_size=256)
    calls = []
    for cls, name in (
        (moderngl.Texture, "read"),
        (moderngl.Texture, "read_into"),
        (moderngl.Framebuffer, "read"),
        (moderngl.Framebuffer, "read_into"),
        (moderngl.Buffer, "read"),
        (moderngl.Buffer, "read_into"),
    ):
        original = getattr(cls, name)
        monkeypatch.setattr(
            cls, name, lambda *a, _o=original, _n=name, **k: calls.append(_n) or _o(*a, **k)
        )
    before = gl.reads
    rng = np.random.default_rng(1)
    for _ in range(100):
        off = rng.uniform(-0.4, 0.4, 2)
        s.tool.model[:3, 3] = [off[0], 0.05, off[1]]
        carver.carve(
            s.target,
            s.tool,
            ContactFrame(np.array([off[0], 0, off[1]]), np.array([0, -1.0, 0])),
            0.003,
            0.001,
        )
    assert gl.reads == before and calls == []
    monkeypatch.undo()
    assert heights(gl, s.target).min() < -0.0029
    release(s)


@pytest.mark.parametrize("map_size", [256, 512])
def test_flat_face_into_sphere_leaves_the_cut_cap(gl, carver, map_size):
    # A box's flat face pressed d into a ball of radius R cuts it by a plane: along the surface
    # normal at angle theta from the press axis, h = min(0, -(d - R (1 - cos theta)) / cos theta).
    # Curved charts put several camera pixels in one texel: this checks the texel-centre estimate.
    radius, depth = 0.2, 0.012
    s = setup(
        gl,
        target="sphere",
        target_size=(radius,),
        tool="box",
        tool_size=(0.2,),
        map_size=map_size,
        tool_map_size=64,
    )
    carver.carve(s.target, s.tool, s.contact, depth)
    _, err = cut_cap_errors(heights(gl, s.target), radius, depth)  # the +Y chart
    assert len(err) > 100
    assert np.sqrt(np.mean(err**2)) <= 0.02 * depth
    assert abs(err.mean()) <= 0.005 * depth  # no bias towards the deepest sample
    release(s)
