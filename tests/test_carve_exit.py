"""Where a texel's point leaves the swept solid (issue 41, items 1-3): the tool moves `depth`
along the press direction, and every target point inside the solid it sweeps moves inwards along
its own normal until it leaves it (docs/carve.md, "What a press means").

Oracles, from the geometry alone: a box swept along a segment is the Minkowski sum of the two, a
convex polytope bounded by the box's face planes (each moved along the segment where it faces
that way) and by the planes through each box edge parallel to the segment (the walls the box's
outline sweeps); a point on a ray from inside leaves it at the nearest of those planes ahead. A
ball swept along a segment is a capsule; a ray from inside leaves it where it leaves the farthest
of its two end spheres and of its cylinder between them."""

from __future__ import annotations

import numpy as np
import pytest

from carve_helpers import heights, release, setup
from dentdemo.carve.cpu_reference import CpuReference
from surface_helpers import texel_points

#: The press of items 1 and 2: a 0.1 m box pressed 30 degrees off the normal into a 1 m plate.
BOX_PRESS = {"tool": "box", "tool_size": (0.1,), "direction": (0.5, -0.8660254, 0.0)}
#: The press of item 3: a 5 cm ball pressed at 45 degrees into a 0.4 m box, near its +X edge.
EDGE_PRESS = {
    "target": "box",
    "target_size": (0.4,),
    "tool": "sphere",
    "tool_size": (0.05,),
    "offset": (0.19, 0.02),
    "direction": (-1.0, -1.0, 0.0),
}
#: Float32 rounding of view depths (llvmpipe 1e-7 m, an H100 1e-6 m: docs/carve.md).
ROUNDING = 2e-6


def swept_box_exit(
    q: np.ndarray, v: np.ndarray, centre: np.ndarray, half: np.ndarray, sweep: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For points q (k, 3) moving along unit v (k, 3): how far they move before leaving the
    axis-aligned box (centre, half extents) swept along `sweep` (0 where q is not inside it),
    whether q is inside, and whether the plane they leave by is a wall (parallel to the sweep)."""
    axes = np.eye(3)
    normals = [sign * axes[i] for i in range(3) for sign in (1.0, -1.0)]
    for i in range(3):
        m = np.cross(axes[i], sweep)
        if np.linalg.norm(m) > 1e-12:
            normals += [m / np.linalg.norm(m), -m / np.linalg.norm(m)]
    m = np.array(normals)
    # Support of the Minkowski sum along each normal: the box's plus the segment's.
    support = m @ centre + np.abs(m) @ half + np.maximum(0.0, m @ sweep)
    slack = support[None, :] - q @ m.T
    rate = v @ m.T
    ahead = rate > 1e-12
    t = np.where(ahead, slack / np.where(ahead, rate, 1.0), np.inf)
    plane = t.argmin(axis=1)
    inside = slack.min(axis=1) > 1e-12
    wall = np.abs(m[plane] @ sweep) < 1e-9 * np.linalg.norm(sweep)
    return np.where(inside, t[np.arange(len(q)), plane], 0.0), inside, wall


def capsule_exit(
    q: np.ndarray, v: np.ndarray, a: np.ndarray, b: np.ndarray, radius: float
) -> np.ndarray:
    """For points q (k, 3) moving along unit v (k, 3): how far they move before leaving the
    capsule of `radius` around segment a-b (0 where q is not inside it)."""
    ab = b - a
    f = np.clip((q - a) @ ab / (ab @ ab), 0.0, 1.0)
    inside = np.linalg.norm(q - (a + f[:, None] * ab), axis=1) < radius
    far = np.zeros(len(q))
    for centre in (a, b):  # the end spheres
        oc = q - centre
        bq = np.einsum("ij,ij->i", v, oc)
        disc = bq * bq - (np.einsum("ij,ij->i", oc, oc) - radius**2)
        far = np.where(disc >= 0, np.maximum(far, -bq + np.sqrt(np.maximum(disc, 0.0))), far)
    axis = ab / np.linalg.norm(ab)  # the cylinder, where its exit lies between the ends
    vp = v - np.outer(v @ axis, axis)
    op = (q - a) - np.outer((q - a) @ axis, axis)
    qa = np.einsum("ij,ij->i", vp, vp)
    qb = np.einsum("ij,ij->i", vp, op)
    qc = np.einsum("ij,ij->i", op, op) - radius**2
    disc = qb * qb - qa * qc
    ok = (disc >= 0) & (qa > 1e-18)
    t = (-qb + np.sqrt(np.maximum(disc, 0.0))) / np.where(ok, qa, 1.0)
    along = (q - a + t[:, None] * v) @ axis
    ok &= (along >= 0) & (along <= np.linalg.norm(ab))
    far = np.where(ok, np.maximum(far, t), far)
    return np.where(inside, far, 0.0)


def box_press(gl, carver, size: int, depth: float, direction=None):
    """The plate's heights after BOX_PRESS (`direction`: the press's, if not BOX_PRESS's), and
    the oracle's exit depth, inside and wall maps."""
    press = dict(BOX_PRESS, direction=direction or BOX_PRESS["direction"])
    s = setup(gl, map_size=size, tool_map_size=size, **press)
    try:
        carver.carve(s.target, s.tool, s.contact, depth, 0.0)
        h = heights(gl, s.target).astype(np.float64)
        centre = np.asarray(s.tool.model, dtype=np.float64)[:3, 3]
        sweep = depth * s.contact.direction
    finally:
        release(s)
    c = (np.arange(size) + 0.5) / size
    x, z = np.meshgrid(c - 0.5, 0.5 - c)  # the plate's texel centres, y = 0
    q = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], axis=1)
    down = np.tile([0.0, -1.0, 0.0], (len(q), 1))
    exit, inside, wall = swept_box_exit(q, down, centre, np.full(3, 0.05), sweep)
    return h, exit.reshape(h.shape), inside.reshape(h.shape), wall.reshape(h.shape)


@pytest.mark.slow
def test_an_angled_box_press_dents_to_the_swept_box(gl, carver):
    # Item 1: the trailing wedge's wall lines up with the box's outline as the camera sees it
    # (the camera looks along the press), where the nearest camera pixel stood in for the tool:
    # texel [256, 230], 0.2 mm inside the box's edge, was cut 1.687 mm deep at d = 2 mm where the
    # swept box reaches 0.338 mm, 4.638 mm at d = 5 mm (the box reaches 4.330), and shallower
    # at d = 4 mm than at 2 mm.
    previous = None
    for depth in (0.002, 0.003, 0.004, 0.005):
        h, exit, inside, wall = box_press(gl, carver, 512, depth)
        error = np.abs(h + exit)
        # Texels leaving by a wall leave through the tool's outline (10 % of d, the README's
        # bound there); the others by a face of the swept box (2 %).
        assert error[inside & ~wall].max() <= 0.02 * depth, (depth, error[inside & ~wall].max())
        assert error[inside & wall].max() <= 0.1 * depth, (depth, error[inside & wall].max())
        assert (inside & wall).sum() >= 40  # the wedge is there to test (a column at 2 mm)
        assert -h[~inside].min() <= 0.1 * depth  # outside the swept box: at most its outline
        assert -h.min() <= exit.max() + ROUNDING  # never deeper than the swept box reaches
        assert abs(h[256, 230] + exit[256, 230]) <= 0.1 * depth
        if previous is not None:  # deeper presses never leave a texel shallower
            assert (h <= previous + ROUNDING).all(), float((h - previous).max())
        previous = h


def test_a_box_pressed_at_45_degrees_dents_to_the_swept_box(gl, carver):
    # Pass 3 draws no front face far in front of the slab, so part of the box's pixels have no
    # thickness: a texel 0.2 mm inside the box's side wall, whose camera pixel lay on the row of
    # that wall, took a front-less pixel's stand-in thickness for a length and was left undented
    # (1.41 mm short at d = 2 mm).
    depth = 0.002
    h, exit, inside, wall = box_press(gl, carver, 512, depth, direction=(1.0, -1.0, 0.0))
    error = np.abs(h + exit)
    assert error[inside & ~wall].max() <= 0.02 * depth, float(error[inside & ~wall].max())
    assert error[inside & wall].max() <= 0.1 * depth
    assert -h[~inside].min() <= 0.1 * depth
    assert -h.min() <= exit.max() + ROUNDING


@pytest.mark.slow
def test_an_exit_past_the_cameras_view_is_bounded_by_it(gl, carver):
    # Item 2: at 2048² a texel near the wedge's wall, moved by its view-line estimate, leaves the
    # camera's view; that estimate (d / cos 30°, 5.773 mm) was kept as its depth. The camera
    # holds every point of the swept box that meets the plate: a point off it is out.
    depth = 0.005
    h, exit, inside, wall = box_press(gl, carver, 2048, depth)
    assert exit.max() == pytest.approx(depth * np.cos(np.radians(30.0)), rel=1e-6)
    assert -h.min() <= exit.max() + ROUNDING
    error = np.abs(h + exit)
    assert error[inside & ~wall].max() <= 0.02 * depth  # the leading edge too (was -0.361 mm)
    assert error[inside & wall].max() <= 0.1 * depth
    assert -h[~inside].min() <= 0.1 * depth


def test_a_long_exit_is_followed_to_the_far_side_of_the_tool(gl, carver):
    # Item 3: +X-face texels of a box under a ball pressed at 45° over its edge move inwards (-x)
    # through most of the swept ball: texel [376, 113] leaves it 29.79 mm in. The search doubled
    # its first estimate at most four times and stopped at -17.69 mm, 2.4 mm inside the ball.
    depth, size = 0.006, 768
    s = setup(gl, map_size=size, tool_map_size=size, **EDGE_PRESS)
    try:
        carver.carve(s.target, s.tool, s.contact, depth, 0.0)
        h = heights(gl, s.target).astype(np.float64)
        points = texel_points(s.target.gpu_mesh.mesh, size, s.target.model)
        centre = np.asarray(s.tool.model, dtype=np.float64)[:3, 3]
        end = centre + depth * s.contact.direction
    finally:
        release(s)
    chart = np.isfinite(points[..., 0])
    p = points[chart]
    # A box's outward normal: the axis along which its point reaches the face (half 0.2 m).
    axis = np.argmax(np.abs(p), axis=1)
    normal = np.zeros_like(p)
    normal[np.arange(len(p)), axis] = np.sign(p[np.arange(len(p)), axis])
    exit = np.zeros(h.shape)
    exit[chart] = capsule_exit(p, -normal, centre, end, 0.05)
    assert exit[376, 113] == pytest.approx(0.02979, abs=1e-5)
    assert abs(h[376, 113] + exit[376, 113]) <= 0.02 * depth
    error = np.where(chart, np.abs(h + exit), 0.0)
    assert (exit > 3 * depth).sum() >= 20  # texels that move much farther than d
    assert error.max() <= 0.02 * depth, float(error.max())


@pytest.mark.parametrize("press", ["box", "edge"])
def test_the_cpu_reference_follows_the_exit_search(gl, carver, press):
    # The CPU path mirrors the search (outline look-ups, march, bound): the same heights on the
    # target's chart texels, to float32 rounding.
    kwargs = BOX_PRESS if press == "box" else EDGE_PRESS
    maps = []
    for path in ("gpu", "cpu"):
        s = setup(gl, map_size=512, tool_map_size=512, **kwargs)
        try:
            if path == "gpu":
                carver.carve(s.target, s.tool, s.contact, 0.004, 0.0)
            else:
                CpuReference(gl, carver).carve(s.target, s.tool, s.contact, 0.004, 0.0)
            chart = (gl.read(s.target.maps.mask)[:, :, 0] & 1) == 1
            maps.append(np.where(chart, heights(gl, s.target), 0.0))
        finally:
            release(s)
    gpu, cpu = maps
    assert (gpu < -1e-4).sum() > 100
    assert np.abs(gpu - cpu).max() <= 1e-5
