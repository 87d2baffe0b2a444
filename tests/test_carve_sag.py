"""A built-in sphere or capsule is dented at its texels' points on the smooth solid but clipped to
the footprint's slab at their facet points, which lie inside the solid by up to the facets' sag
(`Mesh.facet_sag`); the slab grows by it (docs/carve.md, "Footprint bound"). Oracle: the dent a
slab pressed into the smooth solid gives each texel, from the geometry of the press."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import Carver
from dentdemo.mesh.primitives import capsule, sphere
from surface_helpers import heights, slab_on, texel_points


def _unit(v) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    return a / np.linalg.norm(a)


#: A coarse built-in solid, the outward direction (local) at which a slab is pressed 6 mm into it
#: and the point on its axis nearest to that contact (the sphere's centre).
_COARSE = {
    "sphere of 6 cells a face, at a cube corner (three charts)": (
        sphere(0.04, 6),
        (1, 1, 1),
        (0, 0, 0),
    ),
    "capsule of 8 sides, mid-facet on its side": (
        capsule(0.04, 0.1, around=8, rings=2),
        (math.cos(math.pi / 8), math.sin(math.pi / 8), 0),
        (0, 0, 0.02),
    ),
}


@pytest.mark.parametrize("case", list(_COARSE))
def test_a_coarse_solid_takes_the_whole_dent_of_its_smooth_surface(gl, bodies, case):
    """A slab pressed 6 mm into a coarse sphere (15-degree facets, at a corner where three charts
    meet) or capsule (45-degree facets): every chart texel is dented as its point on the smooth
    solid says, to the rim, and none beyond it. The texel's point: the facet point at its centre
    (the mesh's own uv triangles, in numpy) moved along the solid's normal onto it, as the carve
    does (docs/carve.md, pass 4, step 1); moved a inwards along that normal n it leaves the slab
    where (p - a n) . N = h (N the outward press normal, h the slab's face after the press):
    a = (p . N - h) / (n . N). Before the slab grew by the facets' sag, the texels whose facet
    points lay past the slab's far side were clipped: the rim of the dent (up to 0.3 mm of it
    on the sphere) was missing."""
    mesh, local, axis_point = _COARSE[case]
    radius, depth, size = 0.04, 0.006, 256
    target = bodies.make(mesh, size)
    outward = _unit(local)
    contact = np.asarray(axis_point, dtype=np.float64) + radius * outward
    tool, n = slab_on(bodies, contact, outward)
    carver = Carver(gl)
    try:
        assert len(carver.carve(target, tool, ContactFrame(contact, -n), depth)) == 1
    finally:
        carver.release()
    h = heights(gl, target)
    facet = texel_points(mesh, size)
    chart = ~np.isnan(facet[..., 0])
    centre = _nearest_on_axis(mesh, facet[chart])
    normal = facet[chart] - centre
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    point = centre + radius * normal
    face = contact @ outward - depth  # the slab's face, along the outward normal
    reach = point @ outward - face
    inside, outside = reach > 1e-5, reach < -1e-5
    dent = -h[chart]
    assert inside.sum() > 300
    expected = reach[inside] / (normal[inside] @ outward)
    assert float(np.abs(dent[inside] - expected).max()) <= 2e-6
    assert (dent[outside] == 0.0).all()


def _nearest_on_axis(mesh, points: np.ndarray) -> np.ndarray:
    """The points of the solid's axis segment (its bound) nearest to `points` (k, 3)."""
    a, b = (np.asarray(end, dtype=np.float64) for end in mesh.bound.segment)
    ab = b - a
    length2 = float(ab @ ab)
    if length2 == 0.0:
        return np.broadcast_to(a, points.shape)
    t = np.clip((points - a) @ ab / length2, 0.0, 1.0)
    return a + t[:, None] * ab


@pytest.mark.parametrize(
    "mesh",
    [sphere(0.04, 6), sphere(0.1, 32), capsule(0.04, 0.1, around=8, rings=2), capsule(0.02, 0.3)],
    ids=["sphere-6", "sphere-32", "capsule-8", "capsule-64"],
)
def test_facet_sag_holds_every_point_of_every_facet(mesh):
    """`Mesh.facet_sag` bounds how far inside the smooth solid any point of a facet lies: never
    less than the deepest of 66 points sampled on each triangle (barycentric steps of 1/10), and
    not more than twice it (a bound, not a guess)."""
    steps = 10
    weights = (
        np.array(
            [(i, j, steps - i - j) for i in range(steps + 1) for j in range(steps + 1 - i)],
            dtype=np.float64,
        )
        / steps
    )
    corners = mesh.corner_array()  # (m, 3, 3)
    points = np.einsum("kc,mcd->mkd", weights, corners).reshape(-1, 3)
    a, b = (np.asarray(end, dtype=np.float64) for end in mesh.bound.segment)
    ab = b - a
    t = np.clip((points - a) @ ab / max(float(ab @ ab), 1e-300), 0.0, 1.0)
    inside = mesh.bound.radius - np.linalg.norm(points - (a + t[:, None] * ab), axis=1)
    deepest = float(inside.max())
    assert deepest > 0.0
    assert deepest <= mesh.facet_sag() <= 2.0 * deepest
