"""A built-in sphere's triangle lists from its cube atlas in closed form (`carve/cube_lists.py`,
through `footprint.lists_many`): every triangle whose bounding sphere meets a query's box is in
its list of cells (worked out here from the definition over every triangle), that list stays
near that set, the exact list is that set, and a query gets the same lists alone (Python
floats) as in a batch (arrays)."""

from __future__ import annotations

import numpy as np
import pytest

from dentdemo.carve import cube_lists
from dentdemo.carve.footprint import Projected, Rect, lists_many
from dentdemo.model.shapes import Sphere
from surface_helpers import press_mesh


def _meets(mesh, model, origin, axes, rect, slab) -> np.ndarray:
    """The triangles whose bounding sphere meets the box, from the definition: world =
    model (local), camera = axes (world - origin), radii times the pose's scale."""
    centre, radius = mesh.triangle_spheres()
    camera = (centre @ model[:3, :3].T + model[:3, 3] - origin) @ axes.T
    r = radius * np.linalg.norm(model[:3, 0])
    x, y, s = camera.T
    near = (x + r >= rect.x0) & (x - r <= rect.x1) & (y + r >= rect.y0) & (y - r <= rect.y1)
    return np.flatnonzero(near & (s + r >= slab[0]) & (s - r <= slab[1]))


def _queries(seed: int, count: int):
    """Queries (with their definitions' arguments, and whether they are a press's) on spheres
    of 24 and 48 cells a face edge, posed turned, scaled and mirrored: two thirds a press's,
    seen from any side from the sphere's nearest point (along the cube's axes, edges and
    corners for some), the slab from just before it to 0.5 to 30 % of the radius deep and the
    rectangle around the cap that deep; the rest any box near the surface, up to 1.2 radii
    wide, its slab thin or open beyond the far side."""
    rng = np.random.default_rng(seed)
    meshes = [press_mesh(Sphere(0.05), 1), press_mesh(Sphere(0.02), 2)]
    assert [m.bound.grid for m in meshes] == [24, 48]
    queries = []
    for k in range(count):
        mesh = meshes[k % 2]
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        scale = rng.uniform(0.5, 2.0)
        model = np.eye(4)
        model[:3, :3] = q * scale
        model[:3, 3] = rng.normal(scale=0.2, size=3)
        radius = mesh.bound.radius * scale
        local = rng.normal(size=3)
        if k % 5 == 0:
            local = np.sign(np.round(local))  # an axis, an edge or a corner of the cube
            local = local if local.any() else np.array([1.0, 1.0, 1.0])
        local /= np.linalg.norm(local)
        origin = model[:3, :3] @ (local * mesh.bound.radius) + model[:3, 3]
        forward = -(model[:3, :3] @ local) / scale  # the view into the sphere there
        across, _ = np.linalg.qr(np.column_stack([forward, rng.normal(size=(3, 2))]))
        axes = np.array([across[:, 1], np.cross(across[:, 1], forward), forward])
        press = k % 3 != 0
        if press:
            depth = rng.uniform(0.005, 0.3) * radius
            half = np.sqrt(2.0 * radius * depth) * rng.uniform(0.8, 1.5, size=2)
            cx, cy = rng.normal(scale=0.05, size=2) * half
            slab = (-rng.uniform(0.0, 0.05) * radius, depth)
        else:
            axes, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            axes = axes.T  # rows: right, up, forward
            half = rng.uniform(0.01, 1.2, size=2) * radius
            cx, cy = rng.normal(scale=0.05, size=2) * radius
            lo = -rng.uniform(0.0, 0.1) * radius
            slab = (lo, np.inf) if k % 2 else (lo, lo + rng.uniform(0.01, 0.2) * radius)
        rect = Rect(cx - half[0], cx + half[0], cy - half[1], cy + half[1])
        query = (Projected(mesh, model, origin, axes), rect, slab)
        queries.append((query, (mesh, model, origin, axes), press))
    return queries


@pytest.mark.parametrize("seed", range(3))
def test_a_spheres_lists_hold_every_triangle_that_meets_the_box(seed: int) -> None:
    """Of 120 boxes, each list of cells holds every triangle whose bounding sphere meets its
    box, the presses' lists together at most 2.5 times as many; each exact list is just those
    triangles; and each list is the same in a batch and alone."""
    queries = _queries(seed, 120)
    assert cube_lists.ARRAY_QUERIES <= 60
    cells = lists_many([query for query, _, _ in queries], exact=False)
    exact = lists_many([query for query, _, _ in queries])
    wanted, listed = 0, 0
    for (query, args, press), got, just in zip(queries, cells, exact, strict=True):
        assert cube_lists.closed_form(args[0])
        want = _meets(*args, *query[1:])
        assert np.isin(want, got).all()
        assert len(np.unique(got)) == len(got)  # no triangle twice
        assert np.array_equal(np.sort(just), want)
        if press:
            wanted, listed = wanted + len(want), listed + len(got)
        for found, batch in ((lists_many([query], exact=False), got), (lists_many([query]), just)):
            assert np.array_equal(found[0], batch)
    assert wanted > 10_000 and listed <= 2.5 * wanted
