"""Per-body surface maps on the GPU: height (R32F, metres), normal (RGBA8, tangent space) and the
static chart mask (R8UI: whether each texel and its four neighbours lie in a chart), plus the
body's mesh in GPU buffers."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import moderngl
import numpy as np

from dentdemo.carve.constants import shader_defines
from dentdemo.errors import DentdemoError
from dentdemo.gl.context import GLContext, release
from dentdemo.gl.shaders import program, set_uniform
from dentdemo.gl.state import preserved
from dentdemo.mesh.mesh import Mesh
from dentdemo.mesh.thickness import OPEN, closed_thickness, vertex_thickness

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


class _IndexStream:
    """One index buffer that triangle lists are appended to, for many draws a frame.

    Each list (uint32 vertex indices, three a triangle) is written once after the lists
    before it and drawn from its offset for as long as it is held; a list that no longer fits
    starts the buffer over with fresh storage (orphaning), so a batch of hits costs one
    allocation per `capacity` bytes rather than one per draw, and no draw waits on the GPU
    for an earlier draw's indices (NVIDIA's driver did, orphaning a full-mesh buffer before
    each of a batch's draws)."""

    def __init__(self, ctx: moderngl.Context, capacity: int) -> None:
        self.capacity = max(capacity, 1 << 16)  # bytes
        self.buffer = ctx.buffer(reserve=self.capacity, dynamic=True)
        self._end = 0  # bytes written since the last orphaning
        #: id(list) -> (the list, its first index in the buffer); the list is kept so its id
        #: cannot be reused by another array while the entry lives.
        self._placed: dict[int, tuple[np.ndarray, int]] = {}

    def place(self, triangles: np.ndarray, indices: np.ndarray) -> int:
        """The first index of `triangles`' vertex indices in the buffer, written if needed."""
        held = self._placed.get(id(triangles))
        if held is not None and held[0] is triangles:
            return held[1]
        # take(): a quarter of the time of indexing with the array (numpy 2).
        data = indices.take(triangles, axis=0).astype("u4", copy=False).tobytes()
        if self._end + len(data) > self.capacity:
            self.buffer.orphan()
            self._end = 0
            self._placed.clear()
        offset = self._end
        self.buffer.write(data, offset=offset)
        self._end += len(data)
        self._placed[id(triangles)] = (triangles, offset // 4)
        return offset // 4


class GpuMesh:
    """A mesh's vertex and index buffers, shared by every pass that draws it."""

    def __init__(self, gl: GLContext, mesh: Mesh) -> None:
        ctx = gl.ctx
        self.mesh = mesh
        texture_uvs = mesh.uvs if mesh.texture_uvs is None else mesh.texture_uvs
        data = np.hstack(
            [mesh.positions, mesh.normals, mesh.uvs, mesh.tangents, texture_uvs]
        ).astype("f4")
        self.vbo = ctx.buffer(data.tobytes())
        self.ibo = ctx.buffer(mesh.indices.astype("u4").tobytes())
        self._vaos: dict[tuple[int, str], moderngl.VertexArray] = {}
        #: Index buffers of triangle subsets, one per use ("address", "texels0", ...), each a
        #: stream that lists are appended to (see `draw`).
        self._subsets: dict[str, _IndexStream] = {}
        #: The thickness `thickness_vbo` holds per vertex, NaN where not yet known (a mesh that
        #: is not a built-in shape: its vertices are ray cast as hits reach them).
        self._thickness_held: np.ndarray | None = None
        self._ctx = ctx

    @cached_property
    def thickness_vbo(self) -> moderngl.Buffer:
        """The body's thickness under each vertex, local metres (mesh/thickness.py): a built-in
        shape's in full; another mesh's OPEN until `ensure_thickness` fills its footprints."""
        closed = closed_thickness(self.mesh)
        if closed is None:
            closed = np.full(len(self.mesh.positions), OPEN, dtype=np.float32)
        return self._ctx.buffer(closed.astype("f4").tobytes())

    def ensure_thickness(self, triangles: np.ndarray) -> None:
        """Make `thickness_vbo` hold the thickness under the vertices of `triangles` (a hit's
        footprint) before pass 4 draws them: ray cast once per vertex for a mesh that is not a
        built-in shape (mesh/thickness.py), nothing to do for one that is."""
        if closed_thickness(self.mesh) is not None or len(triangles) == 0:
            return
        if self._thickness_held is None:  # what thickness_vbo holds, kept here (no readback)
            self._thickness_held = np.full(len(self.mesh.positions), np.nan, dtype=np.float32)
        vertices = np.unique(self.mesh.indices[triangles])
        vertices = vertices[np.isnan(self._thickness_held[vertices])]
        if len(vertices) == 0:
            return
        self._thickness_held[vertices] = vertex_thickness(self.mesh, vertices)
        # One write over the span of the new vertices; those in it not yet known stay OPEN.
        lo, hi = int(vertices[0]), int(vertices[-1]) + 1
        span = np.nan_to_num(self._thickness_held[lo:hi], nan=OPEN)
        self.thickness_vbo.write(span.astype("f4").tobytes(), offset=4 * lo)

    @cached_property
    def radius(self) -> float:
        """Distance of the farthest vertex from the local origin, metres (a bounding sphere)."""
        return float(np.linalg.norm(self.mesh.positions, axis=1).max())

    _LAYOUT = "3f 3f 2f 4f 2f"
    _NAMES = ("in_position", "in_normal", "in_uv", "in_tangent", "in_texture_uv")

    def vao(self, prog: moderngl.Program, subset: str = "") -> moderngl.VertexArray:
        """A vertex array binding the attributes `prog` uses (cached per program), over all
        triangles or over the index buffer of `subset`."""
        key = (prog.glo, subset)
        if key not in self._vaos:
            used = [n for n in self._NAMES if n in prog]
            fmt = " ".join(
                f if n in used else f"{f[0]}x4"
                for f, n in zip(self._LAYOUT.split(), self._NAMES, strict=True)
            )
            ibo = self._stream(subset).buffer if subset else self.ibo
            buffers = [(self.vbo, fmt, *used)]
            if "in_thickness" in prog:  # the gather's bound (see ensure_thickness)
                buffers.append((self.thickness_vbo, "1f", "in_thickness"))
            self._vaos[key] = self._ctx.vertex_array(prog, buffers, ibo)
        return self._vaos[key]

    def draw(self, prog: moderngl.Program, triangles: np.ndarray | None, subset: str) -> None:
        """Draw triangles `triangles` (indices into the mesh's triangles; None: all) with `prog`
        through the index stream named `subset` (see `_IndexStream`: a list is uploaded once,
        12 bytes a triangle, no read, and drawn again from where it lies)."""
        if triangles is None:
            self.vao(prog).render(moderngl.TRIANGLES)
            return
        if len(triangles) == 0:
            return
        first = self._stream(subset).place(triangles, self.mesh.indices)
        self.vao(prog, subset).render(moderngl.TRIANGLES, vertices=3 * len(triangles), first=first)

    def _stream(self, subset: str) -> _IndexStream:
        """The index stream of `subset`, made when first asked for."""
        stream = self._subsets.get(subset)
        if stream is None:
            stream = self._subsets[subset] = _IndexStream(self._ctx, 4 * self.ibo.size)
        return stream

    def drawer(
        self, triangles: np.ndarray | None, subset: str
    ) -> Callable[[moderngl.Program], None]:
        """`draw` bound to its triangles, for a pass to call with its program."""

        def draw(prog: moderngl.Program) -> None:
            self.draw(prog, triangles, subset)

        return draw

    def release(self) -> None:
        release(*self._vaos.values(), *(s.buffer for s in self._subsets.values()))
        made = self.__dict__.get("thickness_vbo")  # a cached_property, if it was made
        release(self.vbo, self.ibo, *([made] if made is not None else []))


#: The flat tangent-space normal (0, 0, 1) as the RGBA8 normal map holds it (xyz * 0.5 + 0.5).
FLAT_NORMAL = (0.5, 0.5, 1.0, 1.0)


@dataclass
class SurfaceMaps:
    """The maps of one body. Heights in metres along the surface normal (0 pristine, < 0 dent)."""

    height: moderngl.Texture
    normal: moderngl.Texture
    mask: moderngl.Texture
    #: Surface length of one texel along +u and +v, metres.
    texel_metres: tuple[float, float]
    #: Deepest height the map may hold is -max_dent_depth, metres.
    max_dent_depth: float
    height_fbo: moderngl.Framebuffer
    normal_fbo: moderngl.Framebuffer
    #: No height in the map is above this, metres (>= 0; bumps of a start map stand proud). Carves
    #: only lower heights, so it changes only when a map is loaded.
    max_height: float = 0.0

    @property
    def size(self) -> tuple[int, int]:
        return self.height.size

    def release(self) -> None:
        release(self.height_fbo, self.normal_fbo, self.height, self.normal, self.mask)


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
    whole map (on llvmpipe 288 of the 580 ms a 4096² map took to make, and a 64 MiB upload of
    zeros most of the rest). Called inside `preserved`."""
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
