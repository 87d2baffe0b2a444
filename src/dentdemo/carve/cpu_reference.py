"""The paper's own update path, on the CPU, as a reference and for the benchmark: the GPU draws
passes 1-3, the CPU reads the address map and both depth buffers back, computes the new heights and
normals with numpy, and uploads the changed rectangle. Faithful and vectorised: the same math as
the GPU passes (scatter with MIN into a CPU copy of the map, central differences in metres)."""

from __future__ import annotations

import numpy as np

from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody, Carver
from dentdemo.gl.context import GLContext

MIN_COS = 0.2  # as in peel.frag
#: Penetrations below this (m) are depth-buffer quantisation, not contact.
PENETRATION_FLOOR = 2e-6


class CpuReference:
    """Carves like Carver, but steps 4 and 5 run on the CPU. Keeps a CPU copy of each map, as a
    CPU implementation would."""

    def __init__(self, gl: GLContext, carver: Carver) -> None:
        self.gl = gl
        self.carver = carver
        self._mirrors: dict[int, np.ndarray] = {}

    def mirror(self, body: CarveBody) -> np.ndarray:
        """The CPU copy of a body's height map (read once, when the body is first carved)."""
        key = id(body.maps)
        if key not in self._mirrors:
            self._mirrors[key] = self.gl.read(body.maps.height)[:, :, 0].copy()
        return self._mirrors[key]

    def carve(
        self,
        target: CarveBody,
        tool: CarveBody,
        contact: ContactFrame,
        target_depth: float,
        tool_depth: float = 0.0,
    ) -> None:
        for body in (target, tool):
            self.mirror(body)
        jobs = self.carver.measure_passes(target, tool, contact, target_depth, tool_depth)
        results = [
            self._heights(index, job) for index, job in enumerate(jobs)
        ]  # read everything first
        for job, result in zip(jobs, results, strict=True):
            if result is not None:
                self._apply(job.target, *result)

    def _heights(self, index: int, job):
        """Read back passes 1-3 and compute (texel rows, cols, new heights)."""
        slot = self.carver.slot(index)
        w, h = job.camera.resolution
        view = (0, 0, w, h)
        address = self.gl.read_region(slot.address_fbo, view, 4, 0)  # (u, v, height, cos)
        depth_a = self.gl.read_region(slot.address_fbo, view, 1, 1)[:, :, 0]  # metres
        window = self.gl.read_region(slot.address_fbo, view, 1, -1)[:, :, 0]  # depth buffer
        near, far = job.camera.depth_range
        # After the peel the depth buffer holds the tool's depth where it reached past the target.
        depth_b = near + window.astype(np.float64) * (far - near)
        penetration = depth_b - depth_a
        # Where the tool did not pass, the buffer still holds the target's own (quantised) depth.
        hit = (address[:, :, 0] >= 0.0) & (penetration > PENETRATION_FLOOR)
        if not hit.any():
            return None
        size = np.array(job.target.maps.size)
        cos = np.maximum(address[:, :, 3], MIN_COS)
        grid = np.where(hit, address[:, :, 2] - penetration / cos, np.nan)
        grid = np.maximum(grid, -job.target.maps.max_dent_depth)
        uv_grid = address[:, :, :2].astype(np.float64)
        # As the scatter pass: flat charts are sampled at texel centres already (aligned camera).
        curved = job.target.gpu_mesh.mesh.curved
        centred = to_texel_centres(uv_grid, grid, size) if curved else grid
        uv = uv_grid[hit]
        cols = np.clip(np.floor(uv[:, 0] * size[0]).astype(int), 0, size[0] - 1)
        rows = np.clip(np.floor(uv[:, 1] * size[1]).astype(int), 0, size[1] - 1)
        new = np.maximum(centred[hit], -job.target.maps.max_dent_depth)
        return rows, cols, new.astype(np.float32)

    def _apply(self, body: CarveBody, rows, cols, new) -> None:
        maps = body.maps
        mirror = self.mirror(body)
        r0, r1, c0, c1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
        region = mirror[r0:r1, c0:c1]
        np.minimum.at(region, (rows - r0, cols - c0), new)
        maps.height.write(
            np.ascontiguousarray(region).tobytes(), viewport=(c0, r0, c1 - c0, r1 - r0)
        )
        # Normals of the changed rectangle grown by one texel, from central differences in metres.
        H, W = mirror.shape
        R0, R1, C0, C1 = max(r0 - 1, 0), min(r1 + 1, H), max(c0 - 1, 0), min(c1 + 1, W)
        normals = normal_rgba(mirror, (R0, R1, C0, C1), maps.texel_metres)
        maps.normal.write(normals.tobytes(), viewport=(C0, R0, C1 - C0, R1 - R0))


def to_texel_centres(uv: np.ndarray, height: np.ndarray, size: np.ndarray) -> np.ndarray:
    """Move each camera pixel's new height (NaN: none) to the centre of its texel along the local
    gradient d h / d uv from neighbouring pixels, as footprint.vert does."""
    rows, cols = height.shape
    valid = np.isfinite(height)
    sample = np.dstack([uv, height])

    def neighbour(dy: int, dx: int) -> tuple[np.ndarray, np.ndarray]:
        shifted = np.full_like(sample, np.nan)
        ok = np.zeros_like(valid)
        ys = slice(max(dy, 0), rows + min(dy, 0))
        yd = slice(max(-dy, 0), rows + min(-dy, 0))
        xs = slice(max(dx, 0), cols + min(dx, 0))
        xd = slice(max(-dx, 0), cols + min(-dx, 0))
        shifted[yd, xd] = sample[ys, xs]
        ok[yd, xd] = valid[ys, xs]
        same_chart = np.all(np.abs(shifted[..., :2] - uv) * size <= 2.0, axis=-1)
        return shifted, ok & same_chart & valid

    def axis(dy: int, dx: int) -> tuple[np.ndarray, np.ndarray]:
        hi, has_hi = neighbour(dy, dx)
        lo, has_lo = neighbour(-dy, -dx)
        both = has_hi & has_lo
        diff = np.where(
            both[..., None], (hi - lo) * 0.5, np.where(has_hi[..., None], hi - sample, sample - lo)
        )
        return diff, has_hi | has_lo

    dx, ok_x = axis(0, 1)
    dy, ok_y = axis(1, 0)
    det = dx[..., 0] * dy[..., 1] - dy[..., 0] * dx[..., 1]
    usable = valid & ok_x & ok_y & (np.abs(det) >= 1e-12)
    safe = np.where(usable, det, 1.0)
    # grad = inverse(J)^T (dh_x, dh_y), J = [dx.uv | dy.uv] (columns).
    grad_u = (dy[..., 1] * dx[..., 2] - dx[..., 1] * dy[..., 2]) / safe
    grad_v = (-dy[..., 0] * dx[..., 2] + dx[..., 0] * dy[..., 2]) / safe
    texel = np.clip(np.floor(uv * size), 0, size - 1)
    offset = (texel + 0.5) / size - uv
    at_centre = np.all(np.abs(offset) * size < 1e-3, axis=-1)
    moved = height + grad_u * offset[..., 0] + grad_v * offset[..., 1]
    return np.where(usable & ~at_centre, moved, height)


def normal_rgba(height: np.ndarray, box: tuple[int, int, int, int], texel_metres) -> np.ndarray:
    """Tangent-space normals of height[r0:r1, c0:c1] as RGBA8 (one-sided at the map's edges)."""
    r0, r1, c0, c1 = box
    H, W = height.shape
    rows = np.arange(r0, r1)[:, None]
    cols = np.arange(c0, c1)[None, :]
    lo_c, hi_c = np.maximum(cols - 1, 0), np.minimum(cols + 1, W - 1)
    lo_r, hi_r = np.maximum(rows - 1, 0), np.minimum(rows + 1, H - 1)
    du = (height[rows, hi_c] - height[rows, lo_c]) / ((hi_c - lo_c) * texel_metres[0])
    dv = (height[hi_r, cols] - height[lo_r, cols]) / ((hi_r - lo_r) * texel_metres[1])
    n = np.stack([-du, -dv, np.ones_like(du)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    rgb = np.round((n * 0.5 + 0.5) * 255.0)
    return np.concatenate([rgb, np.full(rgb.shape[:2] + (1,), 255.0)], axis=-1).astype(np.uint8)
