"""Built-in meshes, each with a unique UV atlas and gutters between its charts.

Plate (DESIGN.md convention): side S, normal +Y, x = (u - 0.5) S, z = (0.5 - v) S.
Box and cube-sphere: six charts in a 3 x 2 atlas. Capsule and cylinder: surfaces of revolution about
local +Z (ODE's axis), u around the axis, v along the profile. All sizes in metres.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dentdemo.mesh.cube import CUBE_FACES, cube_atlas_indices, grid_indices
from dentdemo.mesh.mesh import Bound, Mesh

#: Gutter around every chart, in uv units (2 texels at 256^2, 32 at 4096^2).
GUTTER = 1.0 / 128.0


def _cell(face: int) -> tuple[float, float, float, float]:
    """uv rectangle (u0, v0, du, dv) of chart `face` in the 3 x 2 atlas, inside its gutter."""
    col, row = face % 3, face // 3
    return (col / 3 + GUTTER, row / 2 + GUTTER, 1 / 3 - 2 * GUTTER, 1 / 2 - 2 * GUTTER)


def plate(side: float, subdivisions: int = 8, thickness: float = 0.0) -> Mesh:
    """The top face of a plate: a square of side `side` at y = 0 covering the whole uv square,
    over `thickness` metres of material (its sides and bottom are drawn apart, never dented)."""
    n = subdivisions
    s = np.linspace(0.0, 1.0, n + 1)
    v, u = np.meshgrid(s, s, indexing="ij")
    uv = np.stack([u.ravel(), v.ravel()], 1)
    pos = np.stack([(uv[:, 0] - 0.5) * side, np.zeros(len(uv)), (0.5 - uv[:, 1]) * side], 1)
    normals = np.tile([0.0, 1.0, 0.0], (len(uv), 1))
    corners = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]]) * side / 2
    faces = np.stack([corners[[0, 1, 2]], corners[[0, 2, 3]]])
    return Mesh(
        "plate",
        pos,
        normals,
        uv.astype(np.float32),
        grid_indices(n, n, 0),
        bound=Bound(triangles=faces, depth=thickness),
    )


def box(size: tuple[float, float, float], subdivisions: int = 4) -> Mesh:
    """A box of full extents `size` (x, y, z) centred at the origin; one chart per face."""
    half = np.asarray(size, dtype=np.float64) / 2.0
    mesh = _cube_atlas(
        "box", subdivisions, lambda n, a, b, s, t: n * half + (s * a + t * b) * half, False
    )
    faces = []
    for nrm, a, b in CUBE_FACES:
        nv, av, bv = (np.asarray(x, dtype=np.float64) for x in (nrm, a, b))
        quad = [(nv + s * av + t * bv) * half for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        faces += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
    mesh.bound = Bound(triangles=np.asarray(faces))
    return mesh


def sphere(radius: float, subdivisions: int = 32) -> Mesh:
    """A cube-sphere with the equal-angle warp (low distortion); one chart per cube face."""

    def place(n, a, b, s, t):
        d = n + np.tan(s * math.pi / 4) * a + np.tan(t * math.pi / 4) * b
        return radius * d / np.linalg.norm(d, axis=1, keepdims=True)

    mesh = _cube_atlas("sphere", subdivisions, place, True)
    mesh.bound = Bound(segment=np.zeros((2, 3)), radius=radius, exact=True, grid=subdivisions)
    return mesh


def _cube_atlas(name: str, n: int, place, curved: bool) -> Mesh:
    positions: list[NDArray[np.float64]] = []
    normals: list[NDArray[np.float64]] = []
    uvs: list[NDArray[np.float64]] = []
    grid = np.linspace(-1.0, 1.0, n + 1)
    t, s = np.meshgrid(grid, grid, indexing="ij")
    s, t = s.ravel()[:, None], t.ravel()[:, None]
    for face, (nrm, a, b) in enumerate(CUBE_FACES):
        nv, av, bv = (np.asarray(x, dtype=np.float64) for x in (nrm, a, b))
        pos = place(nv, av, bv, s, t)
        nr = (
            pos / np.linalg.norm(pos, axis=1, keepdims=True)
            if curved
            else np.tile(nv, (len(pos), 1))
        )
        u0, v0, du, dv = _cell(face)
        uv = np.hstack([u0 + (s + 1) / 2 * du, v0 + (t + 1) / 2 * dv])
        positions.append(pos)
        normals.append(nr)
        uvs.append(uv)
    indices = cube_atlas_indices(n).astype(np.uint32)
    return Mesh(name, np.vstack(positions), np.vstack(normals), np.vstack(uvs), indices)


def _revolve(
    name: str, segments: list[tuple[np.ndarray, np.ndarray, np.ndarray]], around: int
) -> Mesh:
    """Surfaces of revolution about +Z. Each segment is (r, z, profile normal (nr, nz)) sampled
    along the profile; segments meet at sharp edges, so each gets its own rows and v band."""
    lengths = [float(np.hypot(np.diff(r), np.diff(z)).sum()) for r, z, _ in segments]
    total = sum(lengths)
    phi = np.linspace(0.0, 2 * math.pi, around + 1)
    positions: list[NDArray[np.float64]] = []
    normals: list[NDArray[np.float64]] = []
    uvs: list[NDArray[np.float64]] = []
    indices: list[NDArray[np.integer]] = []
    v_start = 0.0
    for (r, z, nrz), length in zip(segments, lengths, strict=True):
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(r), np.diff(z)))]) / max(
            length, 1e-12
        )
        band = length / total
        v = v_start + GUTTER + arc * (band - 2 * GUTTER)
        v_start += band
        rr, pp = np.meshgrid(r, phi, indexing="ij")
        zz = np.repeat(z[:, None], around + 1, 1)
        pos = np.stack([rr * np.cos(pp), rr * np.sin(pp), zz], -1).reshape(-1, 3)
        nr = np.repeat(nrz[:, :1], around + 1, 1)
        nz = np.repeat(nrz[:, 1:], around + 1, 1)
        nrm = np.stack([nr * np.cos(pp), nr * np.sin(pp), nz], -1).reshape(-1, 3)
        uu = GUTTER + phi / (2 * math.pi) * (1 - 2 * GUTTER)
        uv = np.stack(np.meshgrid(v, uu, indexing="ij")[::-1], -1).reshape(-1, 2)
        indices.append(grid_indices(len(r) - 1, around, sum(len(p) for p in positions)))
        positions.append(pos)
        normals.append(nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12))
        uvs.append(uv)
    return Mesh(name, np.vstack(positions), np.vstack(normals), np.vstack(uvs), np.vstack(indices))


def capsule(radius: float, length: float, around: int = 64, rings: int = 16) -> Mesh:
    """A capsule along local Z: a cylinder of `length` between two hemispheres of `radius`."""
    theta = np.linspace(-math.pi / 2, math.pi / 2, 2 * rings + 1)
    half = length / 2
    # One smooth profile: bottom hemisphere, the straight side (two rows at the equator), top.
    lower, upper = theta[theta <= 0], theta[theta >= 0]
    r = np.concatenate([radius * np.cos(lower), radius * np.cos(upper)])
    z = np.concatenate([-half + radius * np.sin(lower), half + radius * np.sin(upper)])
    n = np.concatenate(
        [np.stack([np.cos(lower), np.sin(lower)], 1), np.stack([np.cos(upper), np.sin(upper)], 1)]
    )
    mesh = _revolve("capsule", [(r, z, n)], around)
    mesh.bound = Bound(
        segment=np.array([[0.0, 0.0, -half], [0.0, 0.0, half]]),
        radius=radius,
        exact=True,
        rings=rings,
    )
    return mesh


def cylinder(radius: float, length: float, around: int = 64, rings: int = 8) -> Mesh:
    """A closed cylinder along local Z with flat caps (three charts: bottom, side, top)."""
    half = length / 2
    cap = np.linspace(0.0, radius, rings + 1)
    side = np.linspace(-half, half, rings + 1)
    ones = np.ones(rings + 1)
    mesh = _revolve(
        "cylinder",
        [
            (cap, -half * ones, np.stack([0 * ones, -ones], 1)),
            (radius * ones, side, np.stack([ones, 0 * ones], 1)),
            (cap[::-1], half * ones, np.stack([0 * ones, ones], 1)),
        ],
        around,
    )
    # The capsule around the cylinder holds it.
    mesh.bound = Bound(segment=np.array([[0.0, 0.0, -half], [0.0, 0.0, half]]), radius=radius)
    return mesh


def sphere_texel_areas(radius: float, rows: int, cols: int) -> NDArray[np.float64]:
    """The area on a built-in sphere of `radius` that each texel of a rows x cols map of its atlas
    covers, m^2 (row 0 at v = 0), 0 outside the six charts: the equal-angle warp's area element
    R^2 (pi/4)^2 (1 + X^2)(1 + Y^2) / (1 + X^2 + Y^2)^(3/2) per unit of s and t (X = tan(s pi/4),
    Y = tan(t pi/4), s and t in [-1, 1] across a chart) at the texel's centre, times its extent
    in s and t."""
    u = (np.arange(cols) + 0.5) / cols
    v = (np.arange(rows) + 0.5) / rows
    area = np.zeros((rows, cols))
    for face in range(len(CUBE_FACES)):
        u0, v0, du, dv = _cell(face)
        s = (u - u0) / du * 2.0 - 1.0
        t = (v - v0) / dv * 2.0 - 1.0
        x2 = np.tan(s * math.pi / 4)[None, :] ** 2
        y2 = np.tan(t * math.pi / 4)[:, None] ** 2
        element = radius**2 * (math.pi / 4) ** 2 * (1 + x2) * (1 + y2) / (1 + x2 + y2) ** 1.5
        inside = (np.abs(t) <= 1.0)[:, None] & (np.abs(s) <= 1.0)[None, :]
        area += np.where(inside, element * (2.0 / (du * cols)) * (2.0 / (dv * rows)), 0.0)
    return area
