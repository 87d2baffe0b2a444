"""The displacement fallback's render mesh (where GL has no tessellation): every triangle cut into
k x k by its barycentric grid, each new vertex's attributes interpolated from the corners exactly
as render/displace.tese does on the GPU for an edge level k, so both paths draw the same surface.
Local metres; texture addresses stay the mesh's, so the maps apply unchanged."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dentdemo.mesh.mesh import Mesh

#: Most cuts per edge of the fallback mesh (k^2 triangles per triangle): 16 makes 256.
MAX_CUTS = 16


def barycentric_grid(k: int) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The points (i, j) with i + j <= k of a triangle's grid as barycentric weights (p, 3) of
    corners 0, 1, 2, and its k^2 triangles (k^2, 3), wound like the triangle."""
    points = [(k - i - j, i, j) for j in range(k + 1) for i in range(k + 1 - j)]
    index = {(i, j): n for n, (_, i, j) in enumerate(points)}
    triangles = []
    for j in range(k):
        for i in range(k - j):
            triangles.append((index[i, j], index[i + 1, j], index[i, j + 1]))
            if i + j + 1 < k:
                triangles.append((index[i + 1, j], index[i + 1, j + 1], index[i, j + 1]))
    return np.asarray(points, np.float64) / k, np.asarray(triangles, np.int64)


def refine(mesh: Mesh, k: int) -> Mesh:
    """`mesh` with each triangle cut into k^2 (k >= 1): positions, uvs and texture addresses
    interpolated linearly; normals and tangent directions interpolated and normalised, the
    tangent's handedness taken from the triangle's first corner."""
    if not 1 <= k <= MAX_CUTS:
        raise ValueError(f"refine: cuts per edge must be 1 to {MAX_CUTS}, got {k}")
    weights, template = barycentric_grid(k)
    corners = mesh.indices.astype(np.int64)  # (t, 3)

    def blend(values: NDArray) -> NDArray[np.float32]:
        per_corner = np.asarray(values, np.float64)[corners]  # (t, 3, c)
        mixed = np.einsum("pk,tkc->tpc", weights, per_corner).reshape(-1, per_corner.shape[2])
        return mixed.astype(np.float32)

    def unit(v: NDArray[np.float32]) -> NDArray[np.float32]:
        return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-30)

    per_triangle = len(weights)
    handedness = np.repeat(mesh.tangents[corners[:, 0], 3], per_triangle)[:, None]
    texture_uvs = mesh.uvs if mesh.texture_uvs is None else mesh.texture_uvs
    offsets = np.arange(len(corners), dtype=np.int64)[:, None, None] * per_triangle
    return Mesh(
        f"{mesh.name} cut {k}",
        blend(mesh.positions),
        unit(blend(mesh.normals)),
        blend(mesh.uvs),
        (template[None] + offsets).reshape(-1, 3).astype(np.uint32),
        tangents=np.hstack([unit(blend(mesh.tangents[:, :3])), handedness]),
        texture_uvs=blend(texture_uvs),
    )


def cuts_for(edge_metres: float, metres_per_pixel: float, segment_pixels: float, most: int) -> int:
    """Cuts per edge for edges `edge_metres` long to be about `segment_pixels` on screen: the
    next power of two (so a few meshes serve every distance), at most min(most, MAX_CUTS)."""
    wanted = edge_metres / (metres_per_pixel * segment_pixels)
    k = 1
    while k < wanted and k < min(most, MAX_CUTS):
        k *= 2
    return min(k, most, MAX_CUTS)
