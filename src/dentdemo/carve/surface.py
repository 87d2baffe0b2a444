"""Making a body's surface maps on the GPU (gpu/maps.py's `SurfaceMaps`): height (R32F, metres),
normal (RGBA8, tangent space) and the static chart mask (R8UI: whether each texel and its four
neighbours lie in a chart); their size, flattening, start heights and whole-map normals."""

from __future__ import annotations

import warnings
from pathlib import Path

import moderngl
import numpy as np

from dentdemo.carve.constants import shader_defines
from dentdemo.errors import DentdemoError
from dentdemo.gl.context import GLContext, release
from dentdemo.gl.shaders import program, set_uniform
from dentdemo.gl.state import preserved
from dentdemo.gpu.maps import SurfaceMaps
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.mesh.mesh import Mesh

#: Largest map side, texels; a bigger request is capped with a warning.
MAX_MAP_SIZE = 4096
MIN_MAP_SIZE = 16
#: GPU memory per texel of a body's maps: R32F height (4) + RGBA8 normal (4) + R8UI chart mask (1).
BYTES_PER_TEXEL = 4 + 4 + 1


def map_size_for(mesh: Mesh, texels_per_metre: float, cap: int = MAX_MAP_SIZE) -> int:
    """Side of a square map giving about `texels_per_metre` on the mesh's surface."""
    if not np.isfinite(texels_per_metre) or texels_per_metre <= 0:
        raise DentdemoError(f"texels_per_metre must be a positive number, got {texels_per_metre}")
    su, sv = mesh.uv_scale()  # metres per uv unit
    side = int(np.ceil(max(su, sv) * texels_per_metre))
    if side > cap:
        warnings.warn(
            f"{mesh.name}: a {side}^2 map for {texels_per_metre:g} texels/m is capped at {cap}^2",
            stacklevel=2,
        )
        side = cap
    return max(MIN_MAP_SIZE, side)


#: The flat tangent-space normal (0, 0, 1) as the RGBA8 normal map holds it (xyz * 0.5 + 0.5).
FLAT_NORMAL = (0.5, 0.5, 1.0, 1.0)


def create_maps(
    gl: GLContext,
    gpu_mesh: GpuMesh,
    size: int,
    max_dent_depth: float,
    initial_height: np.ndarray | None = None,
) -> SurfaceMaps:
    """Allocate a body's maps, draw its chart mask and build the normals of the start height.
    The host's GL state is left as it was."""
    heights = None
    if initial_height is not None:
        heights = np.ascontiguousarray(initial_height, dtype=np.float32)
        if heights.shape != (size, size):
            raise DentdemoError(
                f"initial height map is {heights.shape}, the body needs {(size, size)}"
            )
        if not np.isfinite(heights).all():
            raise DentdemoError("initial height map holds NaN or infinity")
    with preserved(gl.ctx):
        return _create_maps(gl, gpu_mesh, size, max_dent_depth, heights)


def _create_maps(
    gl: GLContext,
    gpu_mesh: GpuMesh,
    size: int,
    max_dent_depth: float,
    heights: np.ndarray | None,
) -> SurfaceMaps:
    ctx = gl.ctx
    mesh = gpu_mesh.mesh
    height = ctx.texture((size, size), 1, dtype="f4")
    height.filter = (moderngl.NEAREST, moderngl.NEAREST)
    height.repeat_x = height.repeat_y = False
    if heights is not None:
        height.write(np.maximum(heights, -max_dent_depth).tobytes())
    max_height = 0.0 if heights is None else max(float(heights.max()), 0.0)
    normal = ctx.texture((size, size), 4, dtype="f1")
    normal.filter = (moderngl.LINEAR, moderngl.LINEAR)
    normal.repeat_x = normal.repeat_y = False
    mask = _chart_mask(gl, gpu_mesh, size)
    su, sv = mesh.uv_scale()
    maps = SurfaceMaps(
        height=height,
        normal=normal,
        mask=mask,
        texel_metres=(su / size, sv / size),
        max_dent_depth=max_dent_depth,
        height_fbo=ctx.framebuffer([height]),
        normal_fbo=ctx.framebuffer([normal]),
        max_height=max_height,
    )
    if heights is None:
        flatten(maps)
    else:
        rebuild_all_normals(gl, gpu_mesh, maps)
    return maps


def flatten(maps: SurfaceMaps) -> None:
    """A pristine surface's maps, by two clears on the GPU: every height 0 and every normal the
    flat tangent-space one (0, 0, 1). Pass 5 over a map of zero heights gives that normal at
    every texel (the tests compare the two), so a new or repaired body needs no pass over its
    whole map and no upload of zeros, which were most of the time a large map took to make.
    Called inside `preserved`."""
    maps.height_fbo.clear(0.0, 0.0, 0.0, 0.0)
    maps.normal_fbo.clear(*FLAT_NORMAL)


def _chart_mask(gl: GLContext, gpu_mesh: GpuMesh, size: int) -> moderngl.Texture:
    """The chart mask (R8UI, carve/chart.glsl): the charts' coverage drawn in texture space, then
    each texel's bits for itself and its four neighbours."""
    ctx = gl.ctx
    coverage = ctx.texture((size, size), 1, dtype="f1")
    coverage_fbo = ctx.framebuffer([coverage])
    coverage_fbo.use()
    coverage_fbo.clear(0.0)
    ctx.disable(moderngl.CULL_FACE | moderngl.DEPTH_TEST | moderngl.BLEND)
    gpu_mesh.vao(program(gl.cache, ctx, "util/uv_mask.vert", "util/uv_mask.frag")).render(
        moderngl.TRIANGLES
    )
    mask = ctx.texture((size, size), 1, dtype="u1")
    mask.filter = (moderngl.NEAREST, moderngl.NEAREST)  # an integer texture is never filtered
    mask_fbo = ctx.framebuffer([mask])
    mask_fbo.use()
    bits = program(
        gl.cache, ctx, "util/fullscreen.vert", "util/chart_bits.frag", defines=shader_defines()
    )
    coverage.use(0)
    set_uniform(bits, "u_coverage", 0)
    empty = ctx.vertex_array(bits, [])
    empty.render(moderngl.TRIANGLES, vertices=3)
    release(empty, mask_fbo, coverage_fbo, coverage)
    return mask


def rebuild_all_normals(gl: GLContext, gpu_mesh: GpuMesh, maps: SurfaceMaps) -> None:
    """Normals of the whole map through pass 5 (at creation and import only; a hit rebuilds its
    footprint). Texels outside every chart and its gutter stay flat."""
    from dentdemo.carve.texel_passes import rebuild_normals

    with preserved(gl.ctx):
        maps.normal_fbo.clear(*FLAT_NORMAL)
        rebuild_normals(gl, gpu_mesh, maps)


def load_height_png(path: Path, size: int, amplitude: float) -> np.ndarray:
    """A greyscale PNG as a start height map: white = +amplitude metres, black = 0, resized to
    size x size. Image rows run top-down; texture row 0 is v = 0, the image's bottom row."""
    from PIL import Image

    if not (np.isfinite(amplitude) and amplitude >= 0):
        raise DentdemoError(f"{path}: bump height must be a finite number >= 0, got {amplitude}")
    try:
        with Image.open(path) as img:
            img.load()
            if img.mode in ("I;16", "I;16B", "I;16L", "I"):  # 16-bit greyscale: white is 65535
                white, grey = 65535.0, img.convert("F")
            elif img.mode == "F":  # floating-point greyscale (TIFF): white is 1
                white, grey = 1.0, img
            else:  # 8-bit grey, colour (luminance) or palette: white is 255
                white, grey = 255.0, img.convert("L").convert("F")
            grey = grey.resize((size, size), Image.Resampling.BILINEAR)
    except (OSError, ValueError, Image.DecompressionBombError) as exc:
        detail = " ".join(str(exc).split())[:160]
        raise DentdemoError(f"{path}: cannot read the height image ({detail})") from None
    data = np.clip(np.asarray(grey, dtype=np.float32)[::-1] / white, 0.0, 1.0)
    return np.ascontiguousarray(data * amplitude, dtype=np.float32)
