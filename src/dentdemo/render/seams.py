"""Chart seams for displacement: where a mesh's atlas splits the surface, each point of the seam
has a copy per chart, and each copy reads the height map in its own chart. The two readings
differ a little (gutter texels are extrapolated), so moving each copy by its own would open a
crack along the seam. Each vertex gets the texture addresses of its copies in the other charts
(`twins`); the displacement shaders move every copy by the deepest of them (displace.glsl), the
same for all, so the seam stays closed."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dentdemo.mesh.mesh import Mesh

#: Copies of a point lie within this fraction of the mesh's size of each other (the cube-sphere's
#: are computed from two faces' formulas and differ in the last bits).
SAME_POINT = 2.0**-20
#: Texture addresses closer than this are the same chart's.
SAME_ADDRESS = 2.0**-22


def seam_twins(mesh: Mesh) -> NDArray[np.float32]:
    """(n, 4) per vertex: the texture addresses (u, v) of up to two copies of it in other charts,
    the one copy twice where it has one, its own address twice where it is on no seam."""
    n = len(mesh.positions)
    uvs = mesh.uvs.astype(np.float64)
    twins = np.tile(uvs, 2)
    scale = max(float(mesh.bounding_radius), 1e-3) * SAME_POINT
    point = np.unique(
        np.round(mesh.positions / scale).astype(np.int64), axis=0, return_inverse=True
    )[1]
    address = np.round(uvs / SAME_ADDRESS).astype(np.int64)
    distinct = np.unique(np.column_stack([point.ravel(), address]), axis=0)  # point, address
    charts = np.bincount(distinct[:, 0], minlength=n)
    seam_points = np.nonzero(charts >= 2)[0]
    if len(seam_points) == 0:
        return twins.astype(np.float32)
    point = point.ravel()
    by_point: dict[int, list[int]] = {}
    for vertex in np.nonzero(np.isin(point, seam_points))[0].tolist():
        by_point.setdefault(int(point[vertex]), []).append(vertex)
    for vertices in by_point.values():
        seen: dict[tuple[int, int], int] = {}
        for vertex in vertices:
            seen.setdefault((int(address[vertex, 0]), int(address[vertex, 1])), vertex)
        for vertex in vertices:
            own = (int(address[vertex, 0]), int(address[vertex, 1]))
            others = [uvs[v] for key, v in seen.items() if key != own][:2]
            if others:
                twins[vertex, :2] = others[0]
                twins[vertex, 2:] = others[-1]
    return twins.astype(np.float32)
