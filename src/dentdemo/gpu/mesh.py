"""A mesh in GPU buffers: its vertex buffer, its index buffer and the index streams that triangle
subsets are drawn through, shared by every pass that draws it (the carve's and the renderer's)."""

from __future__ import annotations

from collections.abc import Iterable
from functools import cached_property

import moderngl
import numpy as np

from dentdemo.gl.context import GLContext, release
from dentdemo.mesh.mesh import Mesh
from dentdemo.mesh.thickness import OPEN, closed_thickness, vertex_thickness


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
        self.place_many([triangles], indices)
        return self._placed[id(triangles)][1]

    def place_many(self, lists: Iterable[np.ndarray], indices: np.ndarray) -> None:
        """Write those of `lists` not held yet after one another, in one upload (a batch's
        lists of one stream: one call, not one a list)."""
        new = {id(t): t for t in lists if self._placed.get(id(t), (None,))[0] is not t}
        if not new:
            return
        # take(): a quarter of the time of indexing with the array (numpy 2).
        parts = [indices.take(t, axis=0).astype("u4", copy=False) for t in new.values()]
        size = 4 * sum(part.size for part in parts)
        if self._end + size > self.capacity:
            self.capacity = max(self.capacity, size)  # fresh storage, grown if need be
            self.buffer.orphan(self.capacity)
            self._end = 0
            self._placed.clear()
        offset = self._end
        self.buffer.write(np.concatenate(parts).tobytes(), offset=offset)
        for triangles, part in zip(new.values(), parts, strict=True):
            self._placed[id(triangles)] = (triangles, offset // 4)
            offset += 4 * part.size
        self._end = offset


class ListDraw:
    """A draw of a triangle list through an index stream (`GpuMesh.drawer`), `instances` times
    (gl_InstanceID 0 ..): called with a program, it draws; `upload` writes the lists of many
    such draws first, one upload a stream."""

    __slots__ = ("gpu_mesh", "triangles", "subset", "instances")

    def __init__(
        self, gpu_mesh: GpuMesh, triangles: np.ndarray | None, subset: str, instances: int = 1
    ) -> None:
        self.gpu_mesh = gpu_mesh
        self.triangles = triangles
        self.subset = subset
        self.instances = instances

    def __call__(self, prog: moderngl.Program) -> None:
        self.gpu_mesh.draw(prog, self.triangles, self.subset, self.instances)


def upload(draws: Iterable[object]) -> None:
    """Write the triangle lists of those of `draws` that are `ListDraw`s, one upload for the
    lists of each mesh's stream (a batch's draws: one call a stream, not one a list)."""
    streams: dict[tuple[int, str], tuple[GpuMesh, list[np.ndarray]]] = {}
    for draw in draws:
        if isinstance(draw, ListDraw) and draw.triangles is not None and len(draw.triangles):
            key = (id(draw.gpu_mesh), draw.subset)
            streams.setdefault(key, (draw.gpu_mesh, []))[1].append(draw.triangles)
    for (_, subset), (gpu_mesh, lists) in streams.items():
        gpu_mesh.stream(subset).place_many(lists, gpu_mesh.mesh.indices)


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
            ibo = self.stream(subset).buffer if subset else self.ibo
            buffers = [(self.vbo, fmt, *used)]
            if "in_thickness" in prog:  # the gather's bound (see ensure_thickness)
                buffers.append((self.thickness_vbo, "1f", "in_thickness"))
            self._vaos[key] = self._ctx.vertex_array(prog, buffers, ibo)
        return self._vaos[key]

    def draw(
        self,
        prog: moderngl.Program,
        triangles: np.ndarray | None,
        subset: str,
        instances: int = 1,
    ) -> None:
        """Draw triangles `triangles` (indices into the mesh's triangles; None: all) with `prog`
        through the index stream named `subset` (see `_IndexStream`: a list is uploaded once,
        12 bytes a triangle, no read, and drawn again from where it lies), `instances` times."""
        if triangles is None:
            self.vao(prog).render(moderngl.TRIANGLES, instances=instances)
            return
        if len(triangles) == 0:
            return
        first = self.stream(subset).place(triangles, self.mesh.indices)
        self.vao(prog, subset).render(
            moderngl.TRIANGLES, vertices=3 * len(triangles), first=first, instances=instances
        )

    def stream(self, subset: str) -> _IndexStream:
        """The index stream of `subset`, made when first asked for."""
        stream = self._subsets.get(subset)
        if stream is None:
            stream = self._subsets[subset] = _IndexStream(self._ctx, 4 * self.ibo.size)
        return stream

    def drawer(self, triangles: np.ndarray | None, subset: str, instances: int = 1) -> ListDraw:
        """`draw` bound to its triangles, for a pass to call with its program."""
        return ListDraw(self, triangles, subset, instances)

    def release(self) -> None:
        release(*self._vaos.values(), *(s.buffer for s in self._subsets.values()))
        made = self.__dict__.get("thickness_vbo")  # a cached_property, if it was made
        release(self.vbo, self.ibo, *([made] if made is not None else []))
