"""The types a host program needs to carve dents in its own moderngl context (re-exported by
`dentdemo`). Every call here leaves the host's GL state as it found it."""

from __future__ import annotations

import moderngl
import numpy as np
from numpy.typing import NDArray

from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody
from dentdemo.carve.carver import Carver as _Carver
from dentdemo.carve.surface import GpuMesh, SurfaceMaps, create_maps
from dentdemo.gl.context import GLContext
from dentdemo.gl.state import preserved
from dentdemo.mesh.mesh import Mesh


class Contact:
    """Where and which way a press goes: `point` on the target's surface at first touch (world
    metres) and `direction` (world, any length), the way the tool moves into the target."""

    __slots__ = ("point", "direction")

    def __init__(self, point: NDArray[np.float64], direction: NDArray[np.float64]) -> None:
        self.point = np.asarray(point, dtype=np.float64)
        self.direction = np.asarray(direction, dtype=np.float64)


def _wrap(ctx: moderngl.Context) -> GLContext:
    """dentdemo's wrapper of a host context, made once per context (it caches programs)."""
    if not isinstance(ctx.extra, dict):
        ctx.extra = {}
    if "dentdemo" not in ctx.extra:
        ctx.extra["dentdemo"] = GLContext(ctx=ctx, backend="host")
    return ctx.extra["dentdemo"]


class DentableSurface:
    """A mesh that takes dents: its triangles on the GPU and its maps, sized `map_size` texels.

    `height` (R32F, metres along the surface normal, < 0 in a dent) and `normal` (RGBA8,
    tangent space, xyz * 0.5 + 0.5; sample with the mesh's uv, row 0 at v = 0) are textures to
    bind in the host's shaders. `model` is the pose (4x4, world from local, metres). The mesh is
    never changed; `mesh` needs unique texture coordinates (see `mesh_from_triangles`).
    """

    __slots__ = ("_gl", "mesh", "model", "_gpu", "_maps")

    def __init__(
        self,
        ctx: moderngl.Context,
        mesh: Mesh,
        map_size: int = 1024,
        max_dent_depth: float = 0.01,
        model: NDArray[np.float64] | None = None,
    ) -> None:
        self._gl = _wrap(ctx)
        self.mesh = mesh
        self.model = np.eye(4) if model is None else np.asarray(model, dtype=np.float64)
        with preserved(ctx):
            self._gpu = GpuMesh(self._gl, mesh)
            self._maps: SurfaceMaps = create_maps(self._gl, self._gpu, map_size, max_dent_depth)

    @property
    def height(self) -> moderngl.Texture:
        return self._maps.height

    @property
    def normal(self) -> moderngl.Texture:
        return self._maps.normal

    def heights(self) -> NDArray[np.float32]:
        """The height map read back to the CPU, [v, u] metres (for saving and inspection; a
        frame loop binds `height` instead)."""
        with preserved(self._gl.ctx):
            return self._gl.read(self._maps.height)[:, :, 0]

    def release(self) -> None:
        self._maps.release()
        self._gpu.release()

    def _body(self) -> CarveBody:
        return CarveBody(self._gpu, self._maps, self.model)


class Carver:
    """Carves dents: `press` moves a tool surface into a target surface along a contact."""

    __slots__ = ("_ctx", "_carver")

    def __init__(self, ctx: moderngl.Context) -> None:
        self._ctx = ctx
        with preserved(ctx):
            self._carver = _Carver(_wrap(ctx))

    def press(
        self,
        target: DentableSurface,
        tool: DentableSurface,
        contact: Contact,
        depth: float,
        tool_depth: float = 0.0,
    ) -> bool:
        """Dent `target` `depth` metres deep where `tool` (posed at first touch) moves into it
        along `contact`, and `tool` by `tool_depth`; normals are rebuilt around the dents. A
        press deepens a dent only (the same press twice changes nothing). Nothing is read back.
        False when the bodies cannot meet or the depths are not positive."""
        frame = ContactFrame(contact.point, contact.direction)
        jobs = self._carver.carve(target._body(), tool._body(), frame, depth, tool_depth)
        return bool(jobs)

    def release(self) -> None:
        self._carver.release()
