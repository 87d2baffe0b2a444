"""Dents limited by the material that is there (issue 21, item 3): a texel's dent is never deeper
than the body is thick under it, along its inward normal.

Oracles from geometry alone: a sphere or capsule is 2 r thick through its axis, a box its edge
along the face normal, a plate its thickness, a cylinder 2 r across and its length along the
axis, a torus twice its tube radius; a ray cast into a faceted mesh lands within the facets'
sagitta of those values. The presses: a ball 15 mm into a 10 mm plate, a block 15 mm into a torus
whose tube is 10 mm across, a block 50 mm into a ball 40 mm across; each deeper than the body."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

import dentdemo
from dentdemo.mesh import primitives
from dentdemo.mesh.thickness import OPEN, ray_cast, vertex_thickness


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_built_in_shapes_in_closed_form():
    r, length = 0.03, 0.1
    assert np.all(vertex_thickness(primitives.sphere(r)) == np.float32(2 * r))
    assert np.all(vertex_thickness(primitives.capsule(r, length)) == np.float32(2 * r))
    size = np.array([0.3, 0.05, 0.12])
    box = primitives.box(tuple(size))
    axis = np.argmax(np.abs(box.normals), axis=1)  # each vertex's face: its normal's axis
    assert np.allclose(vertex_thickness(box), size[axis], rtol=1e-6)
    assert np.all(vertex_thickness(primitives.plate(0.5, thickness=0.01)) == np.float32(0.01))
    assert np.all(vertex_thickness(primitives.plate(0.5)) == np.float32(OPEN))  # no slab known
    cyl = primitives.cylinder(r, length)
    cap = np.abs(cyl.normals[:, 2]) > 0.5
    t = vertex_thickness(cyl)
    assert np.allclose(t[cap], length, rtol=1e-6) and np.allclose(t[~cap], 2 * r, rtol=1e-6)


def test_a_scene_plate_carries_its_thickness():
    mesh = dentdemo.shape_mesh(dentdemo.Plate(0.5, thickness=0.015))
    assert np.all(vertex_thickness(mesh) == np.float32(0.015))


@pytest.mark.slow
def test_ray_cast_into_faceted_meshes():
    # A sphere mesh with its closed form taken away: through the centre to the far side.
    sphere = primitives.sphere(0.05, subdivisions=16)
    sphere.bound = None
    t = vertex_thickness(sphere)
    assert np.allclose(t, 0.1, rtol=1e-4)
    # A torus (major 0.1 m, tube 0.01 m): across the tube, within the facets' sagitta.
    ring = trimesh.creation.torus(0.1, 0.01, major_sections=64, minor_sections=32)
    t = vertex_thickness(_mesh_of(ring))
    sagitta = 0.01 * (1 - math.cos(math.pi / 32)) + 0.1 * (1 - math.cos(math.pi / 64))
    assert np.all(np.abs(t - 0.02) <= 2 * sagitta + 1e-6), (t.min(), t.max())
    # An open mesh: a ray that leaves it meets nothing.
    plate = primitives.plate(0.5)
    plate.bound = None
    assert np.all(vertex_thickness(plate) == np.float32(OPEN))
    # Direct: a ray from outside a unit cube's centre line crosses its near face first.
    cube = primitives.box((1.0, 1.0, 1.0))
    hit = ray_cast(cube, np.array([[0.0, 0.0, -3.0]]), _unit(np.array([[0.0, 0.0, 1.0]])))
    assert hit[0] == pytest.approx(2.5)


def _mesh_of(tri: trimesh.Trimesh):
    from dentdemo.mesh.loader import mesh_from_triangles

    with pytest.warns(UserWarning, match="re-atlasing"):  # a torus from trimesh has no uvs
        return mesh_from_triangles(np.asarray(tri.vertices), np.asarray(tri.faces), name="torus")


def test_a_mesh_is_ray_cast_only_where_asked():
    sphere = primitives.sphere(0.05, subdivisions=8)
    sphere.bound = None
    which = np.array([0, 5, 9])
    assert np.allclose(vertex_thickness(sphere, which), 0.1, rtol=1e-4)
    cache = sphere._thickness_cache
    assert np.count_nonzero(~np.isnan(cache)) == len(which)


def _press(gl, target_mesh, target_model, tool_mesh, tool_model, contact, direction, depth):
    ctx = gl.ctx
    target = dentdemo.DentableSurface(ctx, target_mesh, 512, max_dent_depth=0.1)
    target.model = target_model
    tool = dentdemo.DentableSurface(ctx, tool_mesh, 64, max_dent_depth=0.1)
    tool.model = tool_model
    carver = dentdemo.Carver(ctx)
    try:
        assert carver.press(target, tool, dentdemo.Contact(contact, direction), depth)
        return target.heights()
    finally:
        for thing in (carver, tool, target):
            thing.release()


def _at(p) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = p
    return m


def test_a_ball_does_not_go_through_a_plate(gl):
    """A 100 mm ball pressed 15 mm into a 10 mm plate: the dent stops at 10 mm; where the ball's
    cap is shallower than that, it is the cap, depth - (R - sqrt(R^2 - rho^2))."""
    radius, depth, thick = 0.1, 0.015, 0.01
    plate = dentdemo.shape_mesh(dentdemo.Plate(0.2, thickness=thick))
    ball = dentdemo.shape_mesh(dentdemo.Sphere(radius))
    h = _press(gl, plate, np.eye(4), ball, _at((0, radius, 0)), (0, 0, 0), (0, -1, 0), depth)
    assert h.min() == pytest.approx(-thick, abs=1e-7)
    # Texels where the cap is shallower than the plate: the cap depth, to a texel times its
    # slope (rho / sqrt(R^2 - rho^2) < 0.7 there).
    n = h.shape[0]
    texel = 0.2 / n
    x = (np.arange(n) + 0.5) / n * 0.2 - 0.1
    xx, zz = np.meshgrid(x, -x)
    rho = np.hypot(xx, zz)
    cap = depth - (radius - np.sqrt(np.maximum(radius**2 - rho**2, 0.0)))
    shallow = (cap > 0.002) & (cap < thick - 0.002)
    assert np.allclose(-h[shallow], cap[shallow], atol=texel)
    deep = cap > thick + 0.002
    assert deep.any() and np.all(h[deep] == np.float32(-thick))


@pytest.mark.slow
def test_a_block_does_not_cut_through_a_thin_torus(gl):
    """A torus (major 0.1 m, tube 5 mm) pressed 15 mm at its outer equator by a block: the dent
    stops at the tube's 10 mm across (to the facets' sagitta)."""
    ring = trimesh.creation.torus(0.1, 0.005, major_sections=96, minor_sections=32)
    block = primitives.box((0.05, 0.05, 0.05))
    contact = np.array([0.105, 0.0, 0.0])
    h = _press(gl, _mesh_of(ring), np.eye(4), block, _at((0.13, 0, 0)), contact, (-1, 0, 0), 0.015)
    assert h.min() >= -0.010 * (1 + 0.01)
    assert h.min() <= -0.009  # the dent did reach through most of the tube


def test_a_block_does_not_cut_through_a_ball(gl):
    radius = 0.02
    ball = dentdemo.shape_mesh(dentdemo.Sphere(radius))
    block = primitives.box((0.1, 0.1, 0.1))
    h = _press(
        gl, ball, np.eye(4), block, _at((0, radius + 0.05, 0)), (0, radius, 0), (0, -1, 0), 0.05
    )
    assert h.min() == pytest.approx(-2 * radius, abs=1e-6)
