"""The update on the CPU, as a reference and for the benchmark (the paper's own update runs on the
CPU): the GPU draws passes 1-3, the CPU reads the address map and the peeled tool depths back,
then computes passes 4 and 5 with numpy, texel by texel at each texel's own centre, exactly as
docs/carve.md states them, and uploads the changed rectangles. Float64 throughout; it agrees with
the GPU path to float32 rounding."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dentdemo.carve.camera import CollisionCamera, ContactFrame
from dentdemo.carve.carver import CarveBody, CarveJob, Carver
from dentdemo.carve.constants import (
    CHART_SELF,
    EXIT_FIRST_METRES,
    EXIT_MARCH,
    EXIT_STEPS,
    FULL_COVERAGE,
    GUTTER_REACH_TEXELS,
    INSIDE_OUTLINE,
    MIN_COS,
    NO_FRONT,
    NO_SURFACE,
    TOOL_SUBPIXELS,
)
from dentdemo.carve.linear import column_scale
from dentdemo.carve.texel_passes import swept_solid
from dentdemo.gl.context import GLContext
from dentdemo.mesh.thickness import vertex_thickness

Array = NDArray[np.float64]


@dataclass
class Texels:
    """Texels of a map with the surface under each (world metres): rows, cols (ints), world
    point (k, 3), unit normal (k, 3), metres per texel step along +u and +v (k, 3) each, and the
    chart texel a gutter texel takes its normal from (rows, cols)."""

    rows: NDArray[np.int64]
    cols: NDArray[np.int64]
    world: Array
    normal: Array
    per_u: Array
    per_v: Array
    #: The normal of each texel's triangle by the mesh's winding (k, 3), not normalised.
    face: Array
    source_rows: NDArray[np.int64]
    source_cols: NDArray[np.int64]
    gutter: NDArray[np.bool_]
    #: The body's thickness under each texel's point, world metres (mesh/thickness.py).
    thickness: Array


class CpuReference:
    """Carves like Carver, but passes 4 and 5 run on the CPU. Keeps a CPU copy of each body's
    maps, as a CPU implementation would."""

    def __init__(self, gl: GLContext, carver: Carver) -> None:
        self.gl = gl
        self.carver = carver
        self._mirrors: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def mirror(self, body: CarveBody) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CPU copies of a body's height, normal and chart mask (read once, at first use)."""
        key = id(body.maps)
        if key not in self._mirrors:
            # `read` gives new arrays: the normals as they are, the height's one channel copied
            # out contiguous.
            height = np.ascontiguousarray(self.gl.read(body.maps.height)[:, :, 0])
            normal = self.gl.read(body.maps.normal)
            mask = (self.gl.read(body.maps.mask)[:, :, 0] & CHART_SELF) != 0
            self._mirrors[key] = (height, normal, mask)
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
        # Both directions read the heights from before the hit: read everything first.
        results = [self._new_heights(job) for job in jobs]
        for job, (rows, cols, heights) in zip(jobs, results, strict=True):
            self._apply(job, rows, cols, heights)

    # -- pass 4 --------------------------------------------------------------------------------
    def _new_heights(self, job: CarveJob) -> tuple[np.ndarray, ...]:
        scratch = self.carver.scratch
        cam = job.camera
        address = self.gl.read_region(scratch.address_fbo, job.viewport, 4, 0).astype(np.float64)
        # (back depth, coverage, -, front depth)
        tool = self.gl.read_region(scratch.peel_fbo, job.viewport, 4, 0).astype(np.float64)
        _, _, mask = self.mirror(job.target)
        texels = footprint_texels(job.target, cam, cam.slab, mask)
        snap_to_solid(texels, job.target)
        maps = job.target.maps
        swept = bool(job.target_uniforms["u_swept"])
        advance = float(job.target_uniforms["u_advance"])  # type: ignore[arg-type]
        height = gather(
            texels,
            cam,
            address,
            tool,
            maps.max_height,
            maps.max_dent_depth,
            advance,
            swept,
            job.convex,
            job.oblique,
        )
        keep = np.isfinite(height)
        return texels.rows[keep], texels.cols[keep], height[keep]

    def _apply(self, job: CarveJob, rows, cols, heights) -> None:
        body, cam = job.target, job.camera
        height, normal, mask = self.mirror(body)
        if len(rows):
            np.minimum.at(height, (rows, cols), heights.astype(np.float32))
            r0, r1, c0, c1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
            region = np.ascontiguousarray(height[r0:r1, c0:c1])
            body.maps.height.write(region.tobytes(), viewport=(c0, r0, c1 - c0, r1 - r0))
        ring = footprint_texels(body, cam, cam.ring_slab, mask)
        if not len(ring.rows):
            return
        normal[ring.rows, ring.cols] = normal_rgba(height, mask, ring)
        r0, r1 = ring.rows.min(), ring.rows.max() + 1
        c0, c1 = ring.cols.min(), ring.cols.max() + 1
        region = np.ascontiguousarray(normal[r0:r1, c0:c1])
        body.maps.normal.write(region.tobytes(), viewport=(c0, r0, c1 - c0, r1 - r0))


def snap_to_solid(t: Texels, body: CarveBody) -> None:
    """A built-in sphere or capsule: move each texel's point along the solid's normal onto its
    smooth surface (as swept.glsl), in place."""
    solid = swept_solid(body.gpu_mesh.mesh, body.model)
    if solid is None or not len(t.world):
        return
    a, b = np.asarray(solid.u_swept_a), np.asarray(solid.u_swept_b)
    ab = b - a
    length2 = float(ab @ ab)
    f = np.clip((t.world - a) @ ab / length2, 0.0, 1.0) if length2 > 0 else np.zeros(len(t.world))
    axis = a + f[:, None] * ab
    n = t.world - axis
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    t.normal = n
    t.world = axis + solid.u_swept_radius * n


def gather(
    t: Texels,
    cam: CollisionCamera,
    address: np.ndarray,
    tool: np.ndarray,
    ceiling: float,
    max_dent_depth: float,
    advance: float = 0.0,
    swept: bool = False,
    convex: bool = False,
    oblique: bool = True,
) -> Array:
    """Pass 4 for every texel of `t`: the new height (metres), NaN where nothing changes.
    `advance`: how far the tool was advanced (metres); `swept`: the texels lie on a built-in
    sphere or capsule's own solid (SWEPT 1); `convex`: the target hides none of itself, and
    `address` is not read (CONVEX 1); `oblique` False: every normal is the press direction (EXIT
    0: no exit search, the nearest pixel at the tool's outline)."""
    forward = np.asarray(cam.forward, dtype=np.float64)
    cos_view = -(t.normal @ forward)
    face_s = t.face @ forward
    rel = t.world - cam.eye
    depth = rel @ forward
    cols, rows = cam.resolution

    def pixel(r: Array) -> tuple[Array, Array]:
        """Continuous camera-pixel coordinates of offsets `r` from the eye."""
        x = (r @ cam.right / cam.half_extent[0] * 0.5 + 0.5) * cols - 0.5
        y = (r @ cam.up / cam.half_extent[1] * 0.5 + 0.5) * rows - 0.5
        return x, y

    px, py = pixel(rel)
    ix, iy = np.floor(px + 0.5).astype(np.int64), np.floor(py + 0.5).astype(np.int64)
    # Facing: the interpolated normal, or a mesh's triangle (a swept solid's normal is its own).
    front = cos_view > 0 if swept else (cos_view > 0) | (face_s < 0)
    # Hidden: each of the four pixels around the point sees a nearer surface than the texel's
    # own (its point, or its triangle's plane at the pixel), by more than the slope over a pixel.
    slope = np.sqrt(np.maximum(1.0 - cos_view**2, 0.0)) / np.maximum(cos_view, MIN_COS)
    tolerance = float(np.hypot(*cam.pixel_metres)) * (1.0 + slope)
    plane = (not swept) & (np.abs(face_s) > 1e-6 * np.linalg.norm(t.face, axis=1))
    face_x, face_y = t.face @ cam.right, t.face @ cam.up
    pitch_x, pitch_y = cam.pixel_metres
    bx, by = np.floor(px).astype(np.int64), np.floor(py).astype(np.int64)
    visible = np.zeros(len(depth), dtype=bool)
    for dx, dy in ((0, 0), (1, 0), (0, 1), (1, 1)):
        qx, qy = bx + dx, by + dy
        ok = (qx >= 0) & (qy >= 0) & (qx < cols) & (qy < rows)
        addr = address[np.clip(qy, 0, rows - 1), np.clip(qx, 0, cols - 1)]
        with np.errstate(invalid="ignore", divide="ignore"):
            along = depth - (face_x * (qx - px) * pitch_x + face_y * (qy - py) * pitch_y) / face_s
        own = np.where(plane, np.minimum(depth, along), depth)
        visible |= ok & (convex | (addr[:, 0] <= NO_SURFACE) | (addr[:, 2] >= own - tolerance))
    seen = front & visible
    tool_depth, thickness, found = _tool_at(tool, px, py, oblique)
    seen &= found & (thickness > 0.0)  # outside the tool's outline
    # Behind the tool: in front of its nearest face at first touch, or at the outline (no front
    # at the nearest pixel) the front _tool_at extends to the texel (gather.frag).
    inside = (ix >= 0) & (iy >= 0) & (ix < cols) & (iy < rows)
    nearest = np.where(
        inside, tool[np.clip(iy, 0, rows - 1), np.clip(ix, 0, cols - 1), 3], NO_FRONT
    )
    extended = (nearest >= 0.5 * NO_FRONT) & (thickness < 0.5 * INSIDE_OUTLINE)
    nearest = np.where(extended, tool_depth - thickness, nearest)
    seen &= ~((nearest < 0.5 * NO_FRONT) & (depth < nearest - advance - tolerance))

    stretch = 1.0 / np.maximum(cos_view, MIN_COS)
    with np.errstate(invalid="ignore", over="ignore"):
        inward = (tool_depth - depth) * stretch
        # Along the normal, not the view: where the point leaves the swept solid (exit.glsl).
        moving = seen & (inward > 0) & (cos_view < 1.0 - 1e-6) & oblique
        if moving.any():
            inward[moving] = _normal_exit(
                lambda r: _tool_at(tool, *pixel(r)),
                cam,
                rel[moving],
                t.normal[moving],
                depth[moving],
                stretch[moving],
                np.maximum(depth - tool_depth, -thickness)[moving],
                advance,
            )
        h = -inward
    seen &= h < ceiling
    # No deeper than the material's bound, nor than the body is thick under the texel.
    return np.where(seen, np.maximum(h, -np.minimum(max_dent_depth, t.thickness)), np.nan)


def _exit_bound(cam: CollisionCamera, rel: Array, n: Array, depth: Array, stretch: Array) -> Array:
    """exit.glsl's exit_bound: an inward distance (metres) at which each moved point is out of
    the swept solid for certain (past the depth range, or a pixel off the camera's rectangle)."""
    bound = (cam.depth_range[1] - depth) * stretch
    for axis, half, pixels in zip(
        (cam.right, cam.up), cam.half_extent, cam.resolution, strict=True
    ):
        at, drift = rel @ np.asarray(axis), -(n @ np.asarray(axis))
        reach = half * (1.0 + 2.0 / pixels)
        moving = np.abs(drift) > 1e-6
        with np.errstate(divide="ignore", invalid="ignore"):
            limit = (np.sign(drift) * reach - at) / np.where(moving, drift, 1.0)
        bound = np.where(moving, np.minimum(bound, limit), bound)
    return np.maximum(bound, 0.0)


def _normal_exit(
    tool_at: Callable[[Array], tuple[Array, Array, NDArray[np.bool_]]],
    cam: CollisionCamera,
    rel: Array,
    n: Array,
    depth: Array,
    stretch: Array,
    f0: Array,
    start: float,
) -> Array:
    """exit.glsl's normal_exit for many texels at once: from `start` (the press's advance,
    metres, or the bound where the point is out for certain, if nearer) a march by factors of
    two, outwards while the point is inside the swept solid and inwards (not below
    EXIT_FIRST_METRES) while it is out, brackets an exit between a point inside (lo) and one out
    of it (hi); bisection narrows the bracket, and the line through its ends gives the root;
    metres inwards. Every distance looked at is fixed before the tool is (monotone in the
    tool). `f0`: how far inside the solid each point itself lies (metres along the view, < 0)."""

    def beyond(a: Array, which: NDArray[np.int64]) -> tuple[Array, NDArray[np.bool_]]:
        back, thickness, on = tool_at(rel[which] - n[which] * a[:, None])
        return np.maximum(depth[which] + a / stretch[which] - back, -thickness), on

    far = _exit_bound(cam, rel, n, depth, stretch)
    every = np.arange(len(f0))
    lo, f_lo, hi = np.zeros_like(f0), f0.copy(), np.minimum(start, far)
    f_hi, on_hi = beyond(hi, every)
    down = np.flatnonzero(~(on_hi & (f_hi < 0.0)))
    for k in range(EXIT_MARCH):  # inside: look further
        i = np.flatnonzero(on_hi & (f_hi < 0.0))
        if len(i) == 0:
            break
        step = far[i] if k == EXIT_MARCH - 1 else np.minimum(2.0 * hi[i], far[i])
        lo[i], f_lo[i], hi[i] = hi[i], f_hi[i], step
        f_hi[i], on_hi[i] = beyond(step, i)
    stuck = on_hi & (f_hi < 0.0)  # inside at the bound (the depth range misses the tool)
    for _ in range(EXIT_MARCH):  # out at the start: look nearer
        down = down[hi[down] > EXIT_FIRST_METRES]
        if len(down) == 0:
            break
        a = 0.5 * hi[down]
        f, on = beyond(a, down)
        inside = on & (f < 0.0)
        found, out = down[inside], ~inside
        lo[found], f_lo[found] = a[inside], f[inside]
        hi[down[out]], f_hi[down[out]], on_hi[down[out]] = a[out], f[out], on[out]
        down = down[out]
    for _ in range(EXIT_STEPS):
        mid = 0.5 * (lo + hi)
        f, on = beyond(mid, every)
        inside = on & (f < 0.0)
        lo, f_lo = np.where(inside, mid, lo), np.where(inside, f, f_lo)
        hi, f_hi, on_hi = (
            np.where(inside, hi, mid),
            np.where(inside, f_hi, f),
            np.where(inside, on_hi, on),
        )
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.where(on_hi, lo + (hi - lo) / (1.0 + f_hi / -f_lo), 0.5 * (lo + hi))
    return np.where(stuck, hi, root)


def _beyond_outline(near: Array, far_seen: NDArray[np.bool_], far: Array) -> Array:
    """exit.glsl's beyond_outline: (back, thickness) (k, 2) at a pixel without the tool from the
    pixel next to it that sees it and the one beyond that."""
    gain = far[:, 1] - near[:, 1]
    fronts = np.maximum(near[:, 1], far[:, 1]) < 0.5 * INSIDE_OUTLINE  # both have a front face
    with np.errstate(invalid="ignore"):
        linear = far_seen & fronts & (gain > 0) & (near[:, 1] < gain)
    step = np.stack([near[:, 0], -np.abs(near[:, 1])], axis=1)
    extended = 2.0 * near - far
    extended[:, 0] = np.minimum(extended[:, 0], near[:, 0])  # no deeper than near's back
    return np.where(linear[:, None], extended, step)


def _tool_pixels(
    tool: np.ndarray, x: NDArray[np.int64], y: NDArray[np.int64]
) -> tuple[Array, NDArray[np.bool_]]:
    """exit.glsl's tool_pixel: (back, thickness) (k, 2) at pixels (x, y) of the tool's extent,
    and whether each sees the tool."""
    rows, cols = tool.shape[:2]
    inside = (x >= 0) & (y >= 0) & (x < cols) & (y < rows)
    value = tool[np.clip(y, 0, rows - 1), np.clip(x, 0, cols - 1)]
    front = value[:, 3] < 0.5 * NO_FRONT
    thickness = np.where(front, value[:, 0] - value[:, 3], INSIDE_OUTLINE)
    return np.stack([value[:, 0], thickness], axis=1), inside & (value[:, 1] > 0.5)


def _four(tool: np.ndarray, px: Array, py: Array) -> tuple:
    """The four pixels around each position ((bx, by) the lower one, their (back, thickness) and
    whether each sees the tool), whether all four do (the sampler's filtered coverage, with the
    offset as exit.glsl rounds it), and the sampler's blend of their backs there."""
    rows, cols = tool.shape[:2]
    bx, by = np.floor(px).astype(np.int64), np.floor(py).astype(np.int64)
    corner, seen = zip(
        *(_tool_pixels(tool, bx + (k & 1), by + (k >> 1)) for k in range(4)), strict=True
    )
    fx = np.floor(px * TOOL_SUBPIXELS + 0.5) / TOOL_SUBPIXELS - bx
    fy = np.floor(py * TOOL_SUBPIXELS + 0.5) / TOOL_SUBPIXELS - by
    weights = [(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy]
    coverage = sum(w * s for w, s in zip(weights, seen, strict=True))
    in_camera = (bx >= 0) & (by >= 0) & (bx + 1 < cols) & (by + 1 < rows)
    full = in_camera & (coverage >= FULL_COVERAGE)
    with np.errstate(divide="ignore", invalid="ignore"):
        blend = sum(w * s * c[:, 0] for w, s, c in zip(weights, seen, corner, strict=True))
    return bx, by, corner, seen, full, blend / np.where(full, coverage, 1.0)


def _tool_at(
    tool: np.ndarray, px: Array, py: Array, outline: bool = True
) -> tuple[Array, Array, NDArray[np.bool_]]:
    """exit.glsl's tool_at at continuous pixel positions: the tool's back (view depth, metres),
    the thickness there (INSIDE_OUTLINE well inside the outline; <= 0 outside it), and whether
    any of the four pixels around a position sees the tool: the sampler's blend where all four
    do; elsewhere `outline` False (EXIT 0) the nearest pixel's back, True the outline's."""
    bx, by, corner, seen, full, sampled_back = _four(tool, px, py)
    if not outline:
        ix, iy = np.floor(px + 0.5).astype(np.int64), np.floor(py + 0.5).astype(np.int64)
        nearest, has = _tool_pixels(tool, ix, iy)
        back = np.where(full, sampled_back, nearest[:, 0])
        return back, np.full(len(px), INSIDE_OUTLINE), full | has
    offsets = [(k & 1, k >> 1) for k in range(4)]
    # At the outline: each pixel without the tool, the least of what its neighbours along its
    # row and column give (beyond_outline), else its diagonal one's.
    value = [c.copy() for c in corner]
    for k, (dx, dy) in enumerate(offsets):
        least = np.full((len(px), 2), INSIDE_OUTLINE)
        found = np.zeros(len(px), dtype=bool)
        for axis in (1, 2, 3):
            j = k ^ axis
            use = ~seen[k] & seen[j] & ((axis != 3) | ~found)
            nx, ny = bx + (j & 1), by + (j >> 1)
            far, far_seen = _tool_pixels(tool, 2 * nx - bx - dx, 2 * ny - by - dy)
            estimate = _beyond_outline(corner[j], far_seen, far)
            least = np.where(use[:, None], np.minimum(least, estimate), least)
            found |= use
        value[k] = np.where(seen[k][:, None], corner[k], least)
    ux, uy = (px - bx)[:, None], (py - by)[:, None]
    edge = (value[0] * (1 - ux) + value[1] * ux) * (1 - uy) + (
        value[2] * (1 - ux) + value[3] * ux
    ) * uy
    back = np.where(full, sampled_back, edge[:, 0])
    thickness = np.where(full, INSIDE_OUTLINE, edge[:, 1])
    return back, thickness, full | np.logical_or.reduce(seen)


# -- texel enumeration (what passes 4 and 5 rasterise) --------------------------------------------
def footprint_texels(
    body: CarveBody, cam: CollisionCamera, slab: tuple[float, float], mask: np.ndarray
) -> Texels:
    """The texels passes 4 and 5 draw for `body` inside `cam`'s rectangle and `slab` (view
    depth): chart texels whose centre lies in one of the triangles `cam.target_texels`, and
    gutter texels that overlap a chart-border triangle (with the triangle's nearest point)."""
    mesh = body.gpu_mesh.mesh
    model = np.asarray(body.model, dtype=np.float64)
    size = np.array(body.maps.size, dtype=np.float64)  # (columns, rows)
    which = cam.target_texels
    border = mesh.chart_border()[which]
    tri = mesh.indices[which].astype(np.int64)
    uv = mesh.uvs.astype(np.float64)[tri] * size  # (k, 3, 2) texel units
    world = mesh.positions.astype(np.float64)[tri] @ model[:3, :3].T + model[:3, 3]
    normal_matrix = np.linalg.inv(model[:3, :3]).T
    vnormal = mesh.normals.astype(np.float64)[tri] @ normal_matrix.T
    scale = column_scale(model[:3, :3])  # rotation times a scale
    vthick = vertex_thickness(mesh, tri.ravel()).astype(np.float64).reshape(tri.shape) * scale
    lo = np.floor(uv.min(axis=1)).astype(np.int64) - 1
    hi = np.ceil(uv.max(axis=1)).astype(np.int64) + 1
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, size.astype(np.int64) - 1)
    lo, hi = _clip_to_camera(uv, world, cam, lo, hi)
    # Chart texels: centres inside a triangle, found row by row (scanline spans). Gutter texels
    # next to a chart-border triangle: the triangle's nearest point, if the texel overlaps it.
    owner, rows, cols = _spans(uv, lo, hi)
    chart = mask[rows, cols]
    centre = np.stack([cols + 0.5, rows + 0.5], axis=1)
    chart &= _inside(centre, uv[owner])
    g_owner, g_rows, g_cols = _boxes(np.nonzero(border)[0], lo, hi)
    near = ~mask[g_rows, g_cols]
    g_owner, g_rows, g_cols = g_owner[near], g_rows[near], g_cols[near]
    g_centre = np.stack([g_cols + 0.5, g_rows + 0.5], axis=1)
    bary_near, dist = _nearest_barycentric(g_centre, uv[g_owner])
    reach = dist <= GUTTER_REACH_TEXELS
    bary = np.concatenate([_barycentric(centre[chart], uv[owner[chart]]), bary_near[reach]])
    owner = np.concatenate([owner[chart], g_owner[reach]])
    rows = np.concatenate([rows[chart], g_rows[reach]])
    cols = np.concatenate([cols[chart], g_cols[reach]])
    gutter = np.concatenate([np.zeros(chart.sum(), bool), np.ones(reach.sum(), bool)])
    point = np.einsum("kj,kjc->kc", bary, world[owner])
    face = np.cross(world[:, 1] - world[:, 0], world[:, 2] - world[:, 0])[owner]
    n = np.einsum("kj,kjc->kc", bary, vnormal[owner])
    thick = np.einsum("kj,kj->k", bary, vthick[owner])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    # Clip distances of texel.vert / texel.geom: inside the rectangle and the slab.
    rel = point - cam.eye
    inside_cam = (
        (np.abs(rel @ cam.right) <= cam.half_extent[0])
        & (np.abs(rel @ cam.up) <= cam.half_extent[1])
        & (rel @ cam.forward >= slab[0])
        & (rel @ cam.forward <= slab[1])
    )
    # One texel step along +u and along +v on each triangle, world metres.
    dpdu, dpdv = mesh.triangle_derivatives(which)
    per_u, per_v = dpdu @ model[:3, :3].T / size[0], dpdv @ model[:3, :3].T / size[1]
    near_uv = np.einsum("kj,kjc->kc", bary, uv[owner])
    src = np.floor(near_uv).astype(np.int64)
    src_cols, src_rows = _chart_source(src[:, 0], src[:, 1], cols, rows, near_uv, mask, gutter)
    sel = inside_cam & (src_cols >= 0)
    return Texels(
        rows[sel],
        cols[sel],
        point[sel],
        n[sel],
        per_u[owner][sel],
        per_v[owner][sel],
        face[sel],
        src_rows[sel],
        src_cols[sel],
        gutter[sel],
        thick[sel],
    )


def _enumerate(counts: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """For items with `counts`: the item of every element and its index within the item."""
    owner = np.repeat(np.arange(len(counts)), counts)
    return owner, np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)


def _boxes(which, lo, hi):
    """Every texel (owner, row, col) of the boxes lo..hi (inclusive) of triangles `which`."""
    width = np.maximum(hi[which, 0] - lo[which, 0] + 1, 0)
    height = np.maximum(hi[which, 1] - lo[which, 1] + 1, 0)
    item, k = _enumerate(width * height)
    owner = which[item]
    return owner, lo[owner, 1] + k // width[item], lo[owner, 0] + k % width[item]


def _spans(uv, lo, hi):
    """Texels (owner, row, col) whose centres may lie in each triangle (k, 3, 2), row by row
    within the boxes lo..hi: the span between the triangle's edges at the row's centre."""
    item, k = _enumerate(np.maximum(hi[:, 1] - lo[:, 1] + 1, 0))
    row = lo[item, 1] + k
    yc = row + 0.5
    x_lo, x_hi = np.full(len(row), np.inf), np.full(len(row), -np.inf)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        a, b = uv[item, i], uv[item, j]
        dy = b[:, 1] - a[:, 1]
        crossing = ((a[:, 1] - yc) * (b[:, 1] - yc) <= 0) & (dy != 0)
        x = a[:, 0] + (yc - a[:, 1]) / np.where(dy != 0, dy, 1.0) * (b[:, 0] - a[:, 0])
        x_lo = np.where(crossing, np.minimum(x_lo, x), x_lo)
        x_hi = np.where(crossing, np.maximum(x_hi, x), x_hi)
    ok = np.isfinite(x_lo)
    c0 = np.where(ok, np.maximum(np.ceil(x_lo - 0.5 - 1e-9), lo[item, 0]), 0).astype(np.int64)
    c1 = np.where(ok, np.minimum(np.floor(x_hi - 0.5 + 1e-9), hi[item, 0]), -1).astype(np.int64)
    span, k = _enumerate(np.maximum(c1 - c0 + 1, 0))
    return item[span], row[span], c0[span] + k


def _clip_to_camera(uv, world, cam: CollisionCamera, lo, hi):
    """Narrow each triangle's texel box to the preimage of the camera rectangle (affine per
    triangle); edge-on triangles keep their box."""
    rel = world - cam.eye
    x, y = rel @ cam.right, rel @ cam.up  # (k, 3)
    e_uv = np.stack([uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]], axis=2)  # (k, 2, 2) columns
    e_xy = np.stack(
        [
            np.stack([x[:, 1] - x[:, 0], y[:, 1] - y[:, 0]], 1),
            np.stack([x[:, 2] - x[:, 0], y[:, 2] - y[:, 0]], 1),
        ],
        axis=2,
    )
    det = np.linalg.det(e_xy)
    ok = np.abs(det) > 1e-18
    inv = np.linalg.inv(np.where(ok[:, None, None], e_xy, np.eye(2)))
    to_uv = e_uv @ inv  # uv offset per xy offset
    hx, hy = cam.half_extent
    corners = np.array([[-hx, -hy], [hx, -hy], [-hx, hy], [hx, hy]])
    base = np.stack([x[:, 0], y[:, 0]], 1)
    pre = np.einsum("kab,kcb->kca", to_uv, corners[None] - base[:, None]) + uv[:, None, 0]
    plo = np.floor(pre.min(axis=1)).astype(np.int64) - 1
    phi = np.ceil(pre.max(axis=1)).astype(np.int64) + 1
    lo = np.where(ok[:, None], np.maximum(lo, plo), lo)
    hi = np.where(ok[:, None], np.minimum(hi, phi), hi)
    return lo, hi


def _barycentric(q: Array, tri: Array) -> Array:
    """Barycentric weights of points q (k, 2) in triangles (k, 3, 2)."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    r = q - tri[:, 0]
    den = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    b1 = (r[:, 0] * e2[:, 1] - r[:, 1] * e2[:, 0]) / den
    b2 = (e1[:, 0] * r[:, 1] - e1[:, 1] * r[:, 0]) / den
    return np.stack([1 - b1 - b2, b1, b2], axis=1)


def _inside(q: Array, tri: Array) -> NDArray[np.bool_]:
    """Whether points q lie in triangles tri (edges included)."""
    return np.asarray((_barycentric(q, tri) >= 0).all(axis=1), dtype=bool)


def _nearest_barycentric(q: Array, tri: Array) -> tuple[Array, Array]:
    """Barycentric weights of the point of each triangle (k, 3, 2) nearest to q (k, 2), and the
    distance to it (0 inside), as texel.glsl computes them."""
    bary = _barycentric(q, tri)
    dist = np.zeros(len(q))
    outside = (bary < 0).any(axis=1)
    if outside.any():
        best = np.full(outside.sum(), np.inf)
        best_b = np.zeros((outside.sum(), 3))
        t_o, q_o = tri[outside], q[outside]
        for i in range(3):
            j = (i + 1) % 3
            edge = t_o[:, j] - t_o[:, i]
            f = np.clip(((q_o - t_o[:, i]) * edge).sum(1) / (edge * edge).sum(1), 0.0, 1.0)
            d = np.linalg.norm(q_o - (t_o[:, i] + f[:, None] * edge), axis=1)
            better = d < best
            best = np.where(better, d, best)
            b = np.zeros_like(best_b)
            b[:, i], b[:, j] = 1 - f, f
            best_b = np.where(better[:, None], b, best_b)
        bary[outside], dist[outside] = best_b, best
    return bary, dist


def _chart_source(src_c, src_r, cols, rows, near_uv, mask, gutter):
    """The chart texel each texel takes its normal from: itself in a chart; for a gutter texel
    the texel of its nearest triangle point, else the chart neighbour nearest to that point
    (-1: none), as normals.frag."""
    h, w = mask.shape
    src_c, src_r = np.where(gutter, src_c, cols), np.where(gutter, src_r, rows)

    def in_chart(c, r):
        ok = (c >= 0) & (r >= 0) & (c < w) & (r < h)
        return ok & mask[np.clip(r, 0, h - 1), np.clip(c, 0, w - 1)]

    fix = gutter & ~in_chart(src_c, src_r)
    if fix.any():
        near = np.floor(near_uv[fix]) + 0.5  # the centre of the texel holding the nearest point
        best = np.full(fix.sum(), np.inf)
        bc, br = np.full(fix.sum(), -1), np.full(fix.sum(), -1)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                qc, qr = cols[fix] + dx, rows[fix] + dy
                d = np.hypot(qc + 0.5 - near[:, 0], qr + 0.5 - near[:, 1])
                better = in_chart(qc, qr) & (d < best)
                best = np.where(better, d, best)
                bc, br = np.where(better, qc, bc), np.where(better, qr, br)
        src_c, src_r = src_c.copy(), src_r.copy()
        src_c[fix], src_r[fix] = bc, br
    return src_c, src_r


# -- pass 5 --------------------------------------------------------------------------------------
def normal_rgba(height: np.ndarray, mask: np.ndarray, t: Texels) -> np.ndarray:
    """Tangent-space normals (RGBA8) of texels `t` from central differences of `height`,
    one-sided at chart borders, through each texel's metric (as normals.frag)."""
    h, w = height.shape
    r, c = t.source_rows, t.source_cols

    def difference(dr: int, dc: int) -> Array:
        def ok(rr, cc):
            inside = (rr >= 0) & (cc >= 0) & (rr < h) & (cc < w)
            return inside & mask[np.clip(rr, 0, h - 1), np.clip(cc, 0, w - 1)]

        lo_r, lo_c, hi_r, hi_c = r - dr, c - dc, r + dr, c + dc
        has_lo, has_hi = ok(lo_r, lo_c), ok(hi_r, hi_c)
        lo_r, lo_c = np.where(has_lo, lo_r, r), np.where(has_lo, lo_c, c)
        hi_r, hi_c = np.where(has_hi, hi_r, r), np.where(has_hi, hi_c, c)
        span = has_lo.astype(float) + has_hi
        diff = height[hi_r, hi_c].astype(np.float64) - height[lo_r, lo_c]
        return np.where(span >= 1, diff / np.maximum(span, 1), 0.0)

    du, dv = difference(0, 1), difference(1, 0)
    a = np.linalg.norm(t.per_u, axis=1)
    tangent = t.per_u / a[:, None]
    b = (t.per_v * tangent).sum(1)
    cc = np.linalg.norm(t.per_v - b[:, None] * tangent, axis=1)
    grad_t = du / a
    grad_b = (dv - grad_t * b) / cc
    n = np.stack([-grad_t, -grad_b, np.ones_like(du)], axis=1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    rgb = np.round((n * 0.5 + 0.5) * 255.0)
    return np.concatenate([rgb, np.full((len(n), 1), 255.0)], axis=1).astype(np.uint8)
