"""Passes 4 and 5 over a built-in sphere drawn as rectangles of texels (docs/carve.md, "Texel
rectangles"): each fragment finds the facet under its texel centre from the sphere's atlas
(cube_grid.glsl) instead of the rasteriser handing it over. Oracles: the same presses with the
sphere's triangles drawn (the facets are the same, so the dents agree to float32 rounding of the
interpolation), and the number of primitives the two passes draw, which no longer follows the
tessellation: two triangles a chart the footprint meets."""

from __future__ import annotations

import math

import moderngl
import numpy as np
import pytest

from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import Carver, CarverOptions, _Switches
from dentdemo.mesh.primitives import sphere
from surface_helpers import (
    DENTED,
    ball_on,
    heights,
    rotation,
    slab_on,
    tilt,
    translation,
)


def _unit(v) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    return a / np.linalg.norm(a)


#: A sphere target (radius 4 cm; cells per cube-face edge; map texels a side; pose), the outward
#: direction (local) at which it is pressed, the tilt of the press (degrees) and the tool.
_CASES = {
    "face centre, square-on": (32, 256, np.eye(4), (0, 1, 0), 0, "slab"),
    "cube edge (two charts), tilted 30": (32, 256, np.eye(4), (1, 1, 0), 30, "ball"),
    "cube corner (three charts)": (24, 512, np.eye(4), (1, 1, 1), 10, "ball"),
    "turned and scaled 1.5x": (
        32,
        256,
        translation((0.1, 0.2, -0.1)) @ rotation((1, 2, 3), 40) @ np.diag([1.5, 1.5, 1.5, 1.0]),
        (0.3, 0.8, -0.5),
        20,
        "ball",
    ),
    "coarse facets (4 cells a face) at 512": (4, 512, np.eye(4), (0.2, 1, 0.1), 0, "ball"),
    "fine facets (64 cells a face) at 200": (64, 200, np.eye(4), (-0.4, 0.2, 1), 15, "slab"),
}


def _press(bodies, case: str):
    grid, size, model, local, degrees, tool_kind = _CASES[case]
    radius = 0.04
    target = bodies.make(sphere(radius, grid), size, model=model)
    m = np.asarray(model, dtype=np.float64)
    normal = _unit(inverse_transpose(m) @ _unit(local))
    point = m[:3, :3] @ (radius * _unit(local)) + m[:3, 3]
    make = ball_on if tool_kind == "ball" else slab_on
    tool, n = make(bodies, point, normal)
    return target, tool, ContactFrame(point, tilt(n, degrees))


def inverse_transpose(m: np.ndarray) -> np.ndarray:
    return np.linalg.inv(m[:3, :3]).T


@pytest.mark.parametrize("case", list(_CASES))
@pytest.mark.slow
def test_a_sphere_as_texel_rectangles_carves_as_its_triangles_did(gl, bodies, case):
    """Both bodies' heights to 1e-6 m, the same texels dented, and the normals to one step of
    their 8-bit encoding, at a face's centre, across a cube edge and corner (chart borders: the
    gutter draws stay triangles), turned and scaled, on coarse and sub-texel facets; the tool a
    ball (a sphere too, dented as well) or a slab."""
    results = []
    for rects in (0.0, math.inf):  # never, always
        carver = Carver(gl, _switches=_Switches(rect_texels_per_triangle=rects))
        try:
            target, tool, contact = _press(bodies, case)
            assert len(carver.carve(target, tool, contact, 0.004, 0.002)) == 2
            results.append([(b, heights(gl, b), gl.read(b.maps.normal)) for b in (target, tool)])
        finally:
            carver.release()
    for (body, h_tri, n_tri), (_, h_rect, n_rect) in zip(*results, strict=True):
        assert (h_rect < DENTED).sum() > 10  # the slab's dent: about 20 of its 2 mm texels
        assert np.array_equal(h_tri < 0.0, h_rect < 0.0)
        assert float(np.abs(h_tri - h_rect).max()) <= 1e-6
        steps = np.abs(n_tri.astype(np.int16) - n_rect).max(axis=2)
        grid = body.gpu_mesh.mesh.bound.grid
        if not grid:  # not a sphere (the slab): drawn as before, bit for bit
            assert not steps.any()
            continue
        # The rasteriser snaps a triangle's corners to 1/256 of a texel, so a texel centre that
        # close to a facet edge may fall in the other facet, whose texel metric differs.
        ys, xs = np.nonzero(steps > 1)
        assert len(ys) <= 8
        assert (_from_facet_edge(grid, h_rect.shape[0], xs, ys) <= 1 / 64).all()


def _from_facet_edge(grid: int, size: int, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """How far (texels) the centres of texels (xs, ys) of a `size`² map lie from the nearest
    edge of the built-in sphere's facets (mesh/primitives.py: each cube face's chart is a grid of
    `grid` x `grid` cells in its cell of the 3 x 2 atlas inside a gutter of 1/128 uv, each cell
    cut along its diagonal from (0, 0) to (1, 1))."""
    gutter = 1.0 / 128.0
    u, v = (xs + 0.5) / size, (ys + 0.5) / size
    u0 = np.floor(u * 3) / 3 + gutter
    v0 = np.floor(v * 2) / 2 + gutter
    du, dv = 1 / 3 - 2 * gutter, 1 / 2 - 2 * gutter
    fx, fy = ((u - u0) / du * grid) % 1.0, ((v - v0) / dv * grid) % 1.0
    w, h = du * size / grid, dv * size / grid  # a cell's texels
    across = np.minimum(np.minimum(fx, 1 - fx) * w, np.minimum(fy, 1 - fy) * h)
    return np.minimum(across, np.abs(fx - fy) * w * h / math.hypot(w, h))


@pytest.mark.slow
def test_passes_4_and_5_over_a_sphere_draw_two_triangles_whatever_its_tessellation(gl, bodies):
    """A slab pressed square-on onto a cube face's centre (one chart, no chart border in the
    footprint): passes 4 and 5 each draw one rectangle, two triangles, for a sphere of 12, 32 or
    96 cells a face edge; drawn as triangles, the count is the footprint's triangles and grows
    with the tessellation (the query counts what it should)."""
    counts: dict[tuple[bool, int], list[int]] = {}
    for rects in (True, False):
        for grid in (12, 32, 96):
            drawn: list[int] = []

            def counted(name: str, drawn=drawn):  # noqa: ANN202
                return _Primitives(gl.ctx, drawn) if name in ("gather", "normals") else _Null()

            carver = Carver(
                gl,
                CarverOptions(pass_timer=counted),
                _switches=_Switches(rect_texels_per_triangle=math.inf if rects else 0.0),
            )
            try:
                target = bodies.make(sphere(0.04, grid), 256)
                tool, n = slab_on(bodies, (0.0, 0.04, 0.0), (0, 1, 0))
                jobs = carver.carve(target, tool, ContactFrame(np.array([0, 0.04, 0.0]), -n), 0.002)
                assert len(jobs) == 1 and len(jobs[0].camera.target_gutter) == 0
                assert (heights(gl, target) < DENTED).sum() > 20
                counts[rects, grid] = drawn
                if not rects:
                    assert drawn == [len(jobs[0].camera.target_texels)] * 2
            finally:
                carver.release()
    for grid in (12, 32, 96):
        assert counts[True, grid] == [2, 2]
    assert counts[False, 12][0] < counts[False, 32][0] < counts[False, 96][0]


@pytest.mark.parametrize("grid", [12, 24, 96])
@pytest.mark.slow
def test_rectangles_are_drawn_where_the_triangles_are_fine(gl, bodies, grid):
    """By default (`RECT_TEXELS_PER_TRIANGLE`) a sphere's chart texels are drawn as rectangles
    where the footprint's triangles hold at most 3 texels of their charts' boxes each, else as
    the triangles: a 5 cm sphere at 256² of 12 or 24 cells a face (about 40 and 11 texels a
    triangle) keeps its triangles, one of 96 cells (under one) draws two a pass. The boxes are
    worked out here from the triangles' texture coordinates (a cube face is a chart: its 2 n²
    triangles are consecutive)."""
    size = 256
    drawn: list[int] = []
    carver = Carver(
        gl,
        CarverOptions(
            pass_timer=lambda name: _Primitives(gl.ctx, drawn) if name == "gather" else _Null()
        ),
    )
    try:
        target = bodies.make(sphere(0.05, grid), size)
        n = _unit((0.3, 1, 0.2))
        tool, n = slab_on(bodies, 0.05 * n, n)
        jobs = carver.carve(target, tool, ContactFrame(0.05 * n, -n), 0.004)
    finally:
        carver.release()
    cam = jobs[0].camera
    mesh = target.gpu_mesh.mesh
    corners = mesh.uvs[mesh.indices[cam.target_texels]].astype(np.float64) * size  # texels
    face = cam.target_texels // (2 * grid * grid)
    area = 0
    for f in np.unique(face):
        uv = corners[face == f].reshape(-1, 2)
        lo, hi = np.floor(uv.min(axis=0)), np.ceil(uv.max(axis=0))
        area += int(np.prod(hi - lo))
    rects = area <= 3.0 * len(cam.target_texels)
    assert rects == (grid == 96)
    gutter = 2 * len(cam.target_gutter)  # texel.geom: each a strip of two triangles
    expected = 2 * len(np.unique(face)) if rects else len(cam.target_texels)
    assert drawn == [expected + gutter]


class _Primitives:
    """Counts the primitives drawn inside it (GL_PRIMITIVES_GENERATED) into `out`."""

    def __init__(self, ctx: moderngl.Context, out: list[int]) -> None:
        self.query = ctx.query(primitives=True)
        self.out = out

    def __enter__(self) -> None:
        self.query.__enter__()

    def __exit__(self, *exc: object) -> None:
        self.query.__exit__(*exc)
        self.out.append(int(self.query.primitives))


class _Null:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> None:
        return None
