"""Presses on any target surface for the carve-v2 tests: bodies from meshes, contact frames from
analytic surface points, and the oracles' measurements (holes, resampling, rotations)."""

from __future__ import annotations

import math

import numpy as np

from dentdemo.carve.carver import CarveBody
from dentdemo.carve.surface import create_maps
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.mesh.loader import reatlas
from dentdemo.mesh.mesh import Mesh
from dentdemo.mesh.normals import smooth_normals
from dentdemo.mesh.primitives import CUBE_FACES, _cell
from dentdemo.mesh.shapes import Tessellation, shape_mesh
from dentdemo.model.shapes import Box, Shape, Sphere

#: Heights below this (metres) count as dented.
DENTED = -1e-7


class Bodies:
    """Makes carve bodies and releases all of them at the end, even when a test fails."""

    def __init__(self, gl) -> None:
        self.gl = gl
        self._made: list[CarveBody] = []

    def make(
        self,
        mesh: Mesh,
        map_size: int,
        model=None,
        max_dent_depth: float = 0.05,
        initial_height: np.ndarray | None = None,
    ) -> CarveBody:
        gpu = GpuMesh(self.gl, mesh)
        maps = create_maps(self.gl, gpu, map_size, max_dent_depth, initial_height)
        body = CarveBody(gpu, maps)
        if model is not None:
            body.model = np.asarray(model, dtype=np.float64)
        self._made.append(body)
        return body

    def release(self) -> None:
        for body in self._made:
            body.maps.release()
            body.gpu_mesh.release()


def heights(gl, body: CarveBody) -> np.ndarray:
    return gl.read(body.maps.height)[:, :, 0]


def holes(h: np.ndarray) -> int:
    """Undented texels whose four neighbours are all dented (DESIGN.md's 'no holes')."""
    d = h < DENTED
    inner = ~d[1:-1, 1:-1] & d[:-2, 1:-1] & d[2:, 1:-1] & d[1:-1, :-2] & d[1:-1, 2:]
    return int(inner.sum())


def translation(p) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = p
    return m


def rotation(axis, degrees: float) -> np.ndarray:
    """4x4 rotation about a unit axis through the origin (Rodrigues)."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    t = math.radians(degrees)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    m = np.eye(4)
    m[:3, :3] = np.eye(3) + math.sin(t) * k + (1 - math.cos(t)) * (k @ k)
    return m


def tilt(normal, degrees: float) -> np.ndarray:
    """The press direction: -normal tipped by `degrees` towards a fixed tangent."""
    n = np.asarray(normal, dtype=np.float64)
    helper = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    t = np.cross(n, helper)
    t /= np.linalg.norm(t)
    t_ = math.radians(degrees)
    return -(math.cos(t_) * n + math.sin(t_) * t)


def ball_on(bodies: Bodies, point, normal, radius: float = 0.03, map_size: int = 256):
    """A ball touching `point` (world) from the side of `normal`, and its contact frame."""
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    ball = bodies.make(press_mesh(Sphere(radius), 1), map_size)
    ball.model = translation(np.asarray(point, dtype=np.float64) + radius * n)
    return ball, n


def slab_on(bodies: Bodies, point, normal, map_size: int = 256):
    """A 0.5 m x 0.02 m x 0.5 m slab whose top face touches `point` (world) from the side of
    `normal`, turned so that its top faces the point: a plate as a tool (a ball lands on it)."""
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    slab = bodies.make(press_mesh(Box((0.5, 0.02, 0.5)), 1), map_size)
    axis = np.cross([0.0, 1.0, 0.0], n)
    angle = math.degrees(math.acos(np.clip(n[1], -1.0, 1.0)))
    turn = rotation(axis if np.linalg.norm(axis) > 1e-9 else (1.0, 0.0, 0.0), angle)
    slab.model = translation(np.asarray(point, dtype=np.float64) + 0.01 * n) @ turn
    return slab, n


def noisy_sphere_without_uvs(radius: float = 0.2) -> Mesh:
    """An icosphere with smooth deterministic bumps and no UVs, re-atlased by xatlas as the
    mesh loader does for a scan without texture coordinates."""
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    v = np.asarray(ico.vertices, dtype=np.float64)
    bump = 1.0 + 0.04 * np.sin(3 * v[:, 0]) * np.sin(2 * v[:, 1] + 1) + 0.03 * np.cos(4 * v[:, 2])
    positions = v * (radius * bump)[:, None]
    faces = np.asarray(ico.faces, dtype=np.uint32)
    normals, faces, source = smooth_normals(positions, faces)
    positions, normals, uvs, faces = reatlas(positions[source], faces, normals)
    return Mesh("noisy", positions, normals, uvs, faces)


def coarse_from_fine(fine: np.ndarray, factor: int) -> tuple[np.ndarray, np.ndarray]:
    """A fine map sampled at the centres of a map `factor` times coarser: each coarse centre is
    the corner shared by the middle 2 x 2 fine texels, so their mean is the bilinear value. Also
    returns where all four are dented."""
    h, w = fine.shape
    mid = factor // 2
    a = fine[mid - 1 :: factor, mid - 1 :: factor][: h // factor, : w // factor]
    b = fine[mid - 1 :: factor, mid::factor][: h // factor, : w // factor]
    c = fine[mid::factor, mid - 1 :: factor][: h // factor, : w // factor]
    d = fine[mid::factor, mid::factor][: h // factor, : w // factor]
    return (a + b + c + d) / 4.0, np.maximum(np.maximum(a, b), np.maximum(c, d)) < DENTED


def press_mesh(shape: Shape, detail: int = 2) -> Mesh:
    """A built-in shape's mesh at the press tool's tessellation."""
    return shape_mesh(shape, Tessellation.press(detail))


def texel_points(mesh: Mesh, size: int, model=None) -> np.ndarray:
    """The world point (metres) at the centre of every chart texel of a `size`² map, rows along
    v, NaN where no triangle of the atlas holds the centre: the mesh's uv triangles rasterised in
    numpy (barycentric weights at (i + 0.5, j + 0.5) / size), independent of the GPU's."""
    m = np.eye(4) if model is None else np.asarray(model, dtype=np.float64)
    points = np.full((size, size, 3), np.nan)
    uv = mesh.uvs.astype(np.float64) * size
    pos = mesh.positions.astype(np.float64) @ m[:3, :3].T + m[:3, 3]
    for tri in mesh.indices:
        a, b, c = uv[tri]
        lo = np.maximum(np.floor(np.minimum(np.minimum(a, b), c)).astype(int), 0)
        hi = np.minimum(np.ceil(np.maximum(np.maximum(a, b), c)).astype(int), size)
        e1, e2 = b - a, c - a
        den = e1[0] * e2[1] - e1[1] * e2[0]
        if hi[0] <= lo[0] or hi[1] <= lo[1] or abs(den) < 1e-12:
            continue
        x, y = np.meshgrid(np.arange(lo[0], hi[0]) + 0.5, np.arange(lo[1], hi[1]) + 0.5)
        rx, ry = x - a[0], y - a[1]
        b1 = (rx * e2[1] - ry * e2[0]) / den
        b2 = (e1[0] * ry - e1[1] * rx) / den
        inside = (b1 >= 0) & (b2 >= 0) & (b1 + b2 <= 1)
        w = np.stack([1 - b1 - b2, b1, b2], axis=-1)[inside]
        rows, cols = np.nonzero(inside)
        points[rows + lo[1], cols + lo[0]] = w @ pos[tri]
    return points


def chart_coordinates(face: int, size: int) -> tuple[np.ndarray, np.ndarray]:
    """(s, t) of every texel centre of a map of `size` texels a side on cube-atlas chart `face`
    (a box's or a cube-sphere's; -1 .. 1 across the chart, beyond it outside), rows as the map
    stores them."""
    u0, v0, du, dv = _cell(face)
    centres = (np.arange(size) + 0.5) / size
    u, v = np.meshgrid(centres, centres)
    return 2 * (u - u0) / du - 1, 2 * (v - v0) / dv - 1


def sphere_directions(face: int, s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The unit direction (local) of a built-in sphere's point at (s, t) of chart `face`: the
    equal-angle warp, N + tan(s pi/4) A + tan(t pi/4) B normalised."""
    normal, a, b = (np.asarray(x, dtype=np.float64) for x in CUBE_FACES[face])
    d = normal + np.tan(s[..., None] * math.pi / 4) * a + np.tan(t[..., None] * math.pi / 4) * b
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def cut_cap_errors(
    h: np.ndarray, radius: float, depth: float, margin: float = 0.98
) -> tuple[np.ndarray, np.ndarray]:
    """A flat face pressed `depth` into a ball of `radius` straight down (-Y) cuts it by a
    plane: along the surface normal at angle theta from the press axis, the oracle height is
    h = min(0, -(d - R (1 - cos theta)) / cos theta). Over the +Y chart of the ball's height map
    `h` (within `margin` of its edges), where either is dented: (the expected heights there, the
    errors there)."""
    s, t = chart_coordinates(2, h.shape[0])
    inside = (np.abs(s) < margin) & (np.abs(t) < margin)
    cos = sphere_directions(2, s, t)[..., 1]
    expected = np.minimum(0.0, -(depth - radius * (1 - cos)) / cos)
    region = inside & ((expected < 0) | (h < 0))
    return expected[region], h[region] - expected[region]
