"""A press dents only the surface the tool meets (issue 19, item 1): surfaces of the same mesh
that lie behind the tool (a shelf over it, the far wall of a ring around it, an inturned rim, a
ledge overhanging it) neither hide that surface from the collision camera nor take a dent.

Oracle, from the geometry alone: every dented texel's point (the mesh's uv triangles rasterised
in numpy) lies inside the advanced ball (within a texel), and the texel under the contact is
dented by the press depth, as a ball pressed square-on into a surface leaves it."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

import dentdemo
from surface_helpers import DENTED, texel_points

RADIUS = 0.02  # the ball, metres
DEPTH = 0.003  # how far it moves along the press, metres
SIZE = 1024


def _shelf() -> tuple[trimesh.Trimesh, np.ndarray, np.ndarray]:
    """A plate (top at y = 0) and, 50 mm above it, a shelf: one mesh. The ball rests on the
    plate under the shelf and is pressed straight down."""
    plate = trimesh.creation.box((0.3, 0.02, 0.3))
    plate.apply_translation((0, -0.01, 0))
    shelf = trimesh.creation.box((0.3, 0.01, 0.3))
    shelf.apply_translation((0, 0.05, 0))
    return trimesh.util.concatenate([plate, shelf]), np.zeros(3), np.array([0.0, -1.0, 0.0])


def _revolved(profile: list[tuple[float, float]], sections: int = 64) -> trimesh.Trimesh:
    """A closed solid of revolution about +Y from (radius, height) points that start and end on
    the axis."""
    mesh = trimesh.creation.revolve(np.asarray(profile), sections=sections)
    mesh.apply_transform(trimesh.transformations.rotation_matrix(-math.pi / 2, (1, 0, 0)))
    if mesh.volume < 0:  # the profile's direction decides the winding
        mesh.invert()
    assert mesh.is_watertight and mesh.volume > 0
    return mesh


def _bowl() -> tuple[trimesh.Trimesh, np.ndarray, np.ndarray]:
    """A spherical shell (inner radius 0.1 m, wall 1 cm) open only above y = 0.08: its rim
    turns in over the cavity. The ball touches the inner wall 45 degrees below the centre and
    is pressed into it; the view lines back from the ball cross the inturned rim."""
    inner, outer, top = 0.1, 0.11, 0.08
    arcs = []
    for r in (inner, outer):
        start = -math.pi / 2
        end = math.asin(top / r)
        angles = np.linspace(start, end, 40)
        arcs.append([(r * math.cos(a), r * math.sin(a)) for a in angles])
    profile = [(0.0, -inner)] + arcs[0][1:] + arcs[1][::-1][:-1] + [(0.0, -outer)]
    mesh = _revolved(profile[::-1])
    d = np.array([math.sqrt(0.5), -math.sqrt(0.5), 0.0])
    return mesh, d * inner, d


def _torus() -> tuple[trimesh.Trimesh, np.ndarray, np.ndarray]:
    """A ring (major radius 0.1 m, tube radius 0.04 m) about +Y; the ball sits in its hole and
    is pressed outwards into the inner equator (x = 0.06 m), with the far side of the ring
    behind it."""
    ring = trimesh.creation.torus(0.1, 0.04, major_sections=96, minor_sections=48)
    ring.apply_transform(trimesh.transformations.rotation_matrix(-math.pi / 2, (1, 0, 0)))
    return ring, np.array([0.06, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])


def _ledge() -> tuple[trimesh.Trimesh, np.ndarray, np.ndarray]:
    """A plate with a wall at x = 0.1 m whose ledge reaches in over the ball's edge, lower than
    the advanced ball's top but clear of the ball: a surface that overhangs the tool (as a
    bunny's head overhangs a ball pressed under it) without being touched."""
    plate = trimesh.creation.box((0.3, 0.02, 0.3))
    plate.apply_translation((0, -0.01, 0))
    wall = trimesh.creation.box((0.01, 0.0385, 0.3))
    wall.apply_translation((0.105, 0.0385 / 2, 0))
    ledge = trimesh.creation.box((0.098, 0.001, 0.3))
    ledge.apply_translation((0.012 + 0.049, 0.038, 0))
    # The ledge spans x 0.012 .. 0.11 at y 0.0375 .. 0.0385: above the ball (whose surface is at
    # y 0.0360 at x = 0.012) and below the top of the ball advanced 1 mm (y 0.039), so only the
    # tool's own front face at each pixel tells that the ledge lies behind it.
    return trimesh.util.concatenate([plate, wall, ledge]), np.zeros(3), np.array([0.0, -1.0, 0.0])


CASES = {"shelf": _shelf, "bowl": _bowl, "torus": _torus, "ledge": _ledge}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.slow
def test_a_press_dents_only_what_the_tool_meets(gl, case):
    host, contact, direction = CASES[case]()
    depth = 0.001 if case == "ledge" else DEPTH
    ctx = gl.ctx
    target = dentdemo.DentableSurface(ctx, host, SIZE, max_dent_depth=0.01)
    ball = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Sphere(RADIUS)), 64)
    centre = contact - direction * RADIUS  # touching at the contact, moving along `direction`
    ball.model = np.eye(4)
    ball.model[:3, 3] = centre
    carver = dentdemo.Carver(ctx)
    try:
        assert carver.press(target, ball, dentdemo.Contact(contact, direction), depth)
        h = target.heights()
        points = texel_points(target.mesh, SIZE)
    finally:
        for thing in (carver, ball, target):
            thing.release()
    dented = (h < DENTED) & np.isfinite(points[..., 0])  # chart texels (gutters copy them)
    texel = math.sqrt(host.area / np.isfinite(points[..., 0]).sum())  # mean texel side, metres
    # Inside the advanced ball, to two texels.
    reach = np.linalg.norm(points[dented] - (centre + direction * depth), axis=1)
    outside = reach > RADIUS + 2 * texel
    assert not outside.any(), (
        f"{int(outside.sum())} of {int(dented.sum())} dented texels lie outside the ball, up to "
        f"{1000 * float(reach.max() - RADIUS):.1f} mm from it"
    )
    # The texel under the contact is dented by the press depth (the surfaces are flat or curve
    # away from the ball there, so the depth along the normal is the press depth to 10 %).
    near = np.nanargmin(np.linalg.norm(points - contact, axis=2))
    row, col = np.unravel_index(near, h.shape)
    assert h[row, col] == pytest.approx(-depth, rel=0.1), (case, float(h[row, col]))


@pytest.mark.parametrize(
    "direction",
    [(0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0)],
    ids=["away", "sliding-x", "sliding-z"],
)
def test_a_press_that_cannot_dent_returns_false(gl, direction):
    """A ball resting on a plate, moved off it or along it: the advanced ball does not reach
    into the plate (it stays on the plate's side of y = 0), so there is nothing to dent."""
    ctx = gl.ctx
    plate = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Plate(0.4)), 256)
    ball = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Sphere(RADIUS)), 64)
    ball.model = np.eye(4)
    ball.model[1, 3] = RADIUS
    carver = dentdemo.Carver(ctx)
    try:
        moved = carver.press(plate, ball, dentdemo.Contact((0, 0, 0), direction), DEPTH, DEPTH)
        pressed = carver.press(plate, ball, dentdemo.Contact((0, 0, 0), (0, -1, 0)), 0.0, 0.0)
        assert (moved, pressed) == (False, False)
        assert not plate.heights().any() and not ball.heights().any()
        # The same bodies pressed into each other do dent: the refusal is the geometry's.
        assert carver.press(plate, ball, dentdemo.Contact((0, 0, 0), (0, -1, 0)), DEPTH)
        assert plate.heights().min() == pytest.approx(-DEPTH, rel=0.02)
    finally:
        for thing in (carver, ball, plate):
            thing.release()
