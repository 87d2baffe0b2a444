"""Maps without gutter texels: a mesh whose UV triangles tile the unit square (a plate's one
chart) gives every texel centre of its map a chart, so passes 4 and 5 draw no gutter there
(`Mesh.charts_fill_map`). Oracles: hand-made UV layouts, the chart mask the GPU draws, and the
same press carved with the gutter draws."""

from __future__ import annotations

import numpy as np
import pytest

from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import Carver
from dentdemo.carve.constants import CHART_SELF
from dentdemo.mesh.mesh import Mesh
from dentdemo.model.shapes import Box, Plane, Plate, Sphere
from surface_helpers import DENTED, Bodies, heights, press_mesh, translation


def _square(uvs: list[tuple[float, float]], indices: list[tuple[int, int, int]]) -> Mesh:
    """A flat mesh on the plane y = 0 whose positions are its uvs (metres)."""
    uv = np.array(uvs, dtype=np.float32)
    positions = np.stack([uv[:, 0], np.zeros(len(uv)), -uv[:, 1]], axis=1)
    normals = np.tile([0.0, 1.0, 0.0], (len(uv), 1))
    return Mesh("square", positions, normals, uv, np.array(indices, dtype=np.uint32))


#: The unit square's corners and centre: four triangles round the centre tile it.
_CORNERS = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.5, 0.5)]
_FAN = [(0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)]


def test_charts_fill_the_map_only_where_the_triangles_tile_the_unit_square():
    assert _square(_CORNERS, _FAN).charts_fill_map()
    assert _square(_CORNERS[:4], [(0, 1, 2), (0, 2, 3)]).charts_fill_map()
    # A corner pulled in: the border edges leave the square's sides and the area is short.
    inset = [(0.0, 0.0), (1.0, 0.0), (0.99, 0.99), (0.0, 1.0), (0.5, 0.5)]
    assert not _square(inset, _FAN).charts_fill_map()
    # The whole layout shrunk into [0.1, 0.9]: a gutter all round.
    shrunk = [(0.1 + 0.8 * u, 0.1 + 0.8 * v) for u, v in _CORNERS]
    assert not _square(shrunk, _FAN).charts_fill_map()
    # One triangle missing: a hole with border edges inside the square.
    assert not _square(_CORNERS, _FAN[:3]).charts_fill_map()
    # The centre moved outside the square: the area is still 1 (the fan's triangles fold over
    # the centre's two sides), but two triangles turn the other way.
    folded = [*_CORNERS[:4], (1.5, 0.5)]
    assert not _square(folded, _FAN).charts_fill_map()
    # Two charts side by side that split the square at u = 0.5: their shared border is inside.
    halves = [(0.0, 0.0), (0.5, 0.0), (0.5, 1.0), (0.0, 1.0)]
    halves += [(0.5, 0.0), (1.0, 0.0), (1.0, 1.0), (0.5, 1.0)]
    assert not _square(halves, [(0, 1, 2), (0, 2, 3), (4, 5, 6), (4, 6, 7)]).charts_fill_map()


@pytest.mark.parametrize(
    ("shape", "fills"),
    [
        (Plate(0.5), True),
        (Plate(1.0, thickness=0.02), True),
        (Plane(), True),
        (Sphere(0.05), False),
        (Box((0.1, 0.2, 0.3)), False),
    ],
    ids=["plate", "thick-plate", "plane", "sphere", "box"],
)
@pytest.mark.parametrize("size", [16, 37, 300])
def test_the_chart_mask_agrees_every_texel_lies_in_a_chart(gl, shape, fills, size):
    """The GPU's chart mask: where the mesh says its charts fill the map, every texel has its
    chart bit; where not, a map fine enough to resolve the gutter (the sphere's and the box's
    atlases keep 1/128 of uv round each chart) has texels outside every chart."""
    mesh = press_mesh(shape, 2)
    assert mesh.charts_fill_map() is fills
    bodies = Bodies(gl)
    try:
        mask = gl.read(bodies.make(mesh, size).maps.mask)[:, :, 0]
        in_chart = (mask & CHART_SELF) != 0
        if fills:
            assert in_chart.all()
        elif size >= 256:
            assert not in_chart.all()
    finally:
        bodies.release()


def test_a_plate_is_carved_without_gutter_draws_and_as_with_them(gl, monkeypatch):
    """A ball pressed near a plate's edge: the plate's job draws no gutter, and the plate's
    heights and normals are bit for bit those the gutter draws give."""
    r, down = 0.04, np.array([0.0, -1.0, 0.0])
    spot = np.array([0.235, 0.0, -0.24])  # 1.5 cm from one side, 1 cm from another
    bodies = Bodies(gl)
    carver = Carver(gl)

    def carve():
        plate = bodies.make(press_mesh(Plate(0.5), 2), 128)
        ball = bodies.make(press_mesh(Sphere(r), 2), 128, translation(spot + [0.0, r, 0.0]))
        jobs = carver.carve(plate, ball, ContactFrame(spot, down), 0.006, 0.002)
        return plate, jobs

    try:
        plate, jobs = carve()
        (plate_job,) = [job for job in jobs if job.target is plate]
        assert len(plate_job.camera.target_gutter) == 0
        # The same press with the plate's gutter drawn, as before.
        monkeypatch.setattr(Mesh, "charts_fill_map", lambda self: False)
        drawn, drawn_jobs = carve()
        (drawn_job,) = [job for job in drawn_jobs if job.target is drawn]
        assert len(drawn_job.camera.target_gutter) > 0  # the footprint reaches the border
        got, expected = heights(gl, plate), heights(gl, drawn)
        assert (got < DENTED).sum() > 20
        assert np.array_equal(got, expected)
        assert np.array_equal(gl.read(plate.maps.normal), gl.read(drawn.maps.normal))
    finally:
        carver.release()
        bodies.release()
