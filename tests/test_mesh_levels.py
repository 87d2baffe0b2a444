"""Render levels of detail: coarser meshes of the curved shapes stay within their stated chord
error of the true surface (measured against the analytic surface, not the meshing code), keep
the full mesh's texture address at every vertex, and are the ones the renderer draws only where
that error is under half a pixel."""

from __future__ import annotations

import numpy as np
import pytest

from dentdemo.mesh.shapes import SANDBOX, chord_error, coarser_levels, shape_mesh
from dentdemo.model.shapes import Box, Capsule, Cylinder, Plate, Sphere

CURVED = {
    "sphere": Sphere(0.05),
    "capsule": Capsule(0.03, 0.1),
    "cylinder": Cylinder(0.04, 0.1),
}


def _inside_by(shape, points: np.ndarray) -> np.ndarray:
    """How far each point lies inside the shape's true curved surface, metres (analytic)."""
    if isinstance(shape, Sphere):
        return shape.radius - np.linalg.norm(points, axis=1)
    if isinstance(shape, Capsule):
        half = shape.length / 2
        axis = np.zeros_like(points)
        axis[:, 2] = np.clip(points[:, 2], -half, half)
        return shape.radius - np.linalg.norm(points - axis, axis=1)
    radial = np.linalg.norm(points[:, :2], axis=1)  # the cylinder's side
    side = (np.abs(points[:, 2]) < shape.length / 2 - 1e-6) & (radial > 0.9 * shape.radius)
    return (shape.radius - radial)[side]


def _samples(mesh) -> np.ndarray:
    """Points on every triangle: random barycentric ones, the centroid and the edge midpoints
    (where a flat triangle strays farthest from a sphere through its corners)."""
    rng = np.random.default_rng(3)
    bary = np.vstack(
        [
            rng.dirichlet((1.0, 1.0, 1.0), size=120),
            [[1 / 3, 1 / 3, 1 / 3], [0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5]],
        ]
    )
    triangles = mesh.positions[mesh.indices].astype(np.float64)
    return np.einsum("bk,tkd->tbd", bary, triangles).reshape(-1, 3)


@pytest.mark.parametrize("name", CURVED)
@pytest.mark.parametrize("divisor", [1, 2, 4])
def test_chord_error_bounds_the_mesh_and_is_not_loose(name, divisor):
    """Tolerance: the stated error is an upper bound (never below the sampled worst point, give
    or take 1e-8 m of float32 vertex rounding) and within 1.6x of it (a looser bound would keep
    fine meshes longer than needed)."""
    shape = CURVED[name]
    tessellation = SANDBOX.coarser(divisor)
    stated = chord_error(shape, tessellation)
    worst = _inside_by(shape, _samples(shape_mesh(shape, tessellation))).max()
    assert worst <= stated + 1e-8
    assert worst >= stated / 1.6


@pytest.mark.parametrize("name", CURVED)
def test_levels_are_coarser_and_keep_texture_addresses(name):
    """Every vertex a coarser level keeps is a vertex of the full mesh with the same position
    (exactly) and texture address: exactly on the sphere and cylinder; within 1e-3 uv on the
    capsule, whose v follows the arc length of its own (coarser) profile."""
    shape = CURVED[name]
    full = shape_mesh(shape)
    levels = coarser_levels(shape)
    assert [len(level.mesh.indices) < len(full.indices) for level in levels] == [True, True]
    assert levels[0].error < levels[1].error
    uv_tolerance = 1e-3 if name == "capsule" else 1e-6
    for level in levels:
        mesh = level.mesh
        gaps = np.linalg.norm(mesh.positions[:, None, :] - full.positions[None, :, :], axis=2)
        assert gaps.min(axis=1).max() < 1e-7
        for k in range(len(mesh.positions)):
            same = np.flatnonzero(gaps[k] < 1e-7)  # seam vertices come in several copies
            uv_gap = np.abs(full.uvs[same] - mesh.uvs[k]).max(axis=1).min()
            assert uv_gap <= uv_tolerance, (k, uv_gap)


@pytest.mark.parametrize("shape", [Box((0.1, 0.2, 0.3)), Plate(0.5)])
def test_flat_shapes_have_no_levels(shape):
    assert coarser_levels(shape) == []
    assert chord_error(shape, SANDBOX) == 0.0


@pytest.fixture
def ball_scene(gl):
    """A 5 cm ball on its own (no ground) with its levels, and a renderer that shades 320 x 240
    pixels without multisampling, so that silhouettes are plain pixel coverage."""
    from dentdemo.gpu.mesh import GpuMesh
    from dentdemo.render.frame import MeshLevel
    from dentdemo.render.quality import Quality
    from dentdemo.render.renderer import Renderer

    shape = Sphere(0.05)
    full = GpuMesh(gl, shape_mesh(shape))
    levels = tuple(MeshLevel(GpuMesh(gl, lv.mesh), lv.error) for lv in coarser_levels(shape))
    renderer = Renderer(gl, (320, 240), Quality("test", msaa=0, shadow_size=512, shadow_taps=1))
    yield full, levels, renderer
    renderer.release()
    for mesh in (full, *(level.mesh for level in levels)):
        mesh.release()


def _render_ball(renderer, full, distance: float, coarser) -> np.ndarray:
    from dentdemo.model.scene import LightSpec
    from dentdemo.render.camera import OrbitCamera
    from dentdemo.render.frame import DrawItem, FrameDescription, RenderOptions
    from dentdemo.render.looks import GROUND

    camera = OrbitCamera.from_eye(np.array([0.0, 0.0, distance]), np.zeros(3))  # 45 deg fov
    items = [] if coarser is None else [DrawItem(full, np.eye(4), GROUND, coarser=coarser)]
    renderer.render(FrameDescription(items, camera, LightSpec(), RenderOptions(), ground_y=None))
    return renderer.read_rgb().astype(int)


def test_renderer_draws_the_coarsest_level_under_half_a_pixel(ball_scene):
    """At 0.4 m the ball is drawn from its full mesh (the image is the one without levels, while
    the coarsest mesh, were it taken, would move ~200 silhouette pixels); at 4 m from its
    coarsest (the same image as the coarsest alone); at 1.5 m, where the ball is 9.6 pixels in
    radius (0.05 / (1.5 tan 22.5 deg) * 120), the silhouette moves by under half a pixel: fewer
    pixels flip than half its 60-pixel perimeter."""
    from dentdemo.render.frame import MeshLevel

    full, levels, renderer = ball_scene
    coarsest_only = (MeshLevel(levels[-1].mesh, 0.0),)  # claims no error: always taken

    def ball(image, empty):
        return np.abs(image - empty).max(axis=2) > 0

    near_empty = _render_ball(renderer, full, 0.4, None)
    near = _render_ball(renderer, full, 0.4, levels)
    near_full = _render_ball(renderer, full, 0.4, ())
    near_coarse = _render_ball(renderer, full, 0.4, coarsest_only)
    assert np.array_equal(near, near_full)
    assert (ball(near_coarse, near_empty) ^ ball(near_full, near_empty)).sum() > 100

    far = _render_ball(renderer, full, 4.0, levels)
    assert np.array_equal(far, _render_ball(renderer, full, 4.0, coarsest_only))

    mid_empty = _render_ball(renderer, full, 1.5, None)
    mid = ball(_render_ball(renderer, full, 1.5, levels), mid_empty)
    mid_full = ball(_render_ball(renderer, full, 1.5, ()), mid_empty)
    assert mid_full.sum() == pytest.approx(np.pi * 9.6**2, rel=0.1)
    assert (mid ^ mid_full).sum() < 0.5 * 2 * np.pi * 9.6
