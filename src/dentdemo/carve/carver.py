"""The five GPU passes of the carve (DESIGN.md "The carve"), for a target dented by a tool and,
when the tool is deformable too, the tool dented by the target. No GPU->CPU reads; the work of one
hit follows its footprint (the collision camera's pixels), never the size of the maps."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field

import moderngl
import numpy as np
from numpy.typing import NDArray

from dentdemo.carve.camera import CollisionCamera, ContactFrame, collision_camera
from dentdemo.carve.surface import GpuMesh, SurfaceMaps
from dentdemo.gl.context import GLContext, release
from dentdemo.gl.shaders import program, set_uniform

NO_CHANGE = 1.0e30  # pass-3 clear value (see footprint.vert)


@dataclass
class CarveBody:
    """What the carve needs of a body: GPU mesh, maps, and pose (world from local)."""

    gpu_mesh: GpuMesh
    maps: SurfaceMaps
    model: NDArray[np.float64] = field(default_factory=lambda: np.eye(4))

    def centre(self) -> NDArray[np.float64]:
        return np.asarray(self.model, dtype=np.float64)[:3, 3]

    def radius(self) -> float:
        """Bounding radius in world metres (the pose may scale)."""
        scale = float(np.linalg.norm(np.asarray(self.model)[:3, :3], ord=2))
        return self.gpu_mesh.mesh.bounding_radius * scale


@dataclass(frozen=True)
class CarveJob:
    """One direction of a hit: `target` dented by `tool` posed at `tool_model`."""

    target: CarveBody
    tool: CarveBody
    tool_model: NDArray[np.float64]
    camera: CollisionCamera


class _Scratch:
    """Per-slot collision-camera buffers, allocated once at the largest resolution; each hit uses
    (and clears) only its own viewport, so it costs its footprint."""

    def __init__(self, ctx: moderngl.Context, size: int) -> None:
        self.address = ctx.texture((size, size), 4, dtype="f4")
        self.depth_a = ctx.texture((size, size), 1, dtype="f4")
        self.new_height = ctx.texture((size, size), 1, dtype="f4")
        self.depth = ctx.depth_texture((size, size))
        for tex in (self.address, self.depth_a, self.new_height):
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.address_fbo = ctx.framebuffer([self.address, self.depth_a], self.depth)
        self.peel_fbo = ctx.framebuffer([self.new_height], self.depth)
        self.peel_clear_fbo = ctx.framebuffer([self.new_height])

    def release(self) -> None:
        release(
            self.address_fbo,
            self.peel_fbo,
            self.peel_clear_fbo,
            self.address,
            self.depth_a,
            self.new_height,
            self.depth,
        )


class Carver:
    """Carves dents into SurfaceMaps. One per GL context."""

    def __init__(self, gl: GLContext, max_resolution: int = 1023) -> None:
        self.gl = gl
        self.max_resolution = max_resolution
        self._slots = [_Scratch(gl.ctx, max_resolution) for _ in range(2)]
        ctx = gl.ctx
        self._address = program(gl.cache, ctx, "carve/surface.vert", "carve/address.frag")
        self._peel = program(gl.cache, ctx, "carve/surface.vert", "carve/peel.frag")
        self._scatter = program(gl.cache, ctx, "carve/footprint.vert", "carve/scatter.frag")
        # Curved charts: several camera pixels per texel, each moved to the texel centre first.
        self._scatter_curved = program(
            gl.cache, ctx, "carve/footprint.vert", "carve/scatter.frag", defines={"TO_CENTRE": 1}
        )
        self._normals = program(gl.cache, ctx, "carve/footprint.vert", "carve/normals.frag")
        self._points = {
            id(p): ctx.vertex_array(p, [])
            for p in (self._scatter, self._scatter_curved, self._normals)
        }
        #: The cameras of the last hit (for the address-map debug view and tests).
        self.last_jobs: list[CarveJob] = []
        #: Wraps each pass when set (the benchmark's GPU timer queries); names as in DESIGN.md.
        self.pass_timer: Callable[[str], AbstractContextManager] | None = None

    # -- public --------------------------------------------------------------------------------
    def carve(
        self,
        target: CarveBody,
        tool: CarveBody,
        contact: ContactFrame,
        target_depth: float,
        tool_depth: float = 0.0,
    ) -> list[CarveJob]:
        """Dent `target` by `target_depth` metres and `tool` by `tool_depth` metres.

        The tool's pose is at first touch; `contact.direction` is the way the tool moves into the
        target. Both directions read the heights from before this hit (the paper updates a body's
        map only once both are done). Depths that are not positive finite numbers do nothing.
        """
        jobs = self._plan(target, tool, contact, target_depth, tool_depth)
        ctx = self.gl.ctx
        saved_viewport = ctx.viewport
        with self._timed("address"):
            for slot, job in zip(self._slots, jobs, strict=False):
                self._address_pass(slot, job)
        with self._timed("peel"):
            for slot, job in zip(self._slots, jobs, strict=False):
                self._peel_pass(slot, job)
        with self._timed("scatter"):
            for slot, job in zip(self._slots, jobs, strict=False):
                curved = job.target.gpu_mesh.mesh.curved
                scatter = self._scatter_curved if curved else self._scatter
                self._footprint_pass(slot, job, scatter, job.target.maps.height_fbo, blend_min=True)
        with self._timed("normals"):
            for slot, job in zip(self._slots, jobs, strict=False):
                self._footprint_pass(
                    slot, job, self._normals, job.target.maps.normal_fbo, blend_min=False
                )
        ctx.viewport = saved_viewport
        ctx.scissor = None
        ctx.disable(
            moderngl.BLEND | moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.PROGRAM_POINT_SIZE
        )
        ctx.blend_equation = moderngl.FUNC_ADD
        ctx.depth_func = "<"
        if jobs:
            self.last_jobs = jobs
        return jobs

    def _timed(self, name: str) -> AbstractContextManager:
        return self.pass_timer(name) if self.pass_timer else contextlib.nullcontext()

    def measure_passes(
        self,
        target: CarveBody,
        tool: CarveBody,
        contact: ContactFrame,
        target_depth: float,
        tool_depth: float = 0.0,
    ) -> list[CarveJob]:
        """Passes 1-3 only, for the CPU reference path (which then reads their buffers back)."""
        jobs = self._plan(target, tool, contact, target_depth, tool_depth)
        for slot, job in zip(self._slots, jobs, strict=False):
            self._address_pass(slot, job)
            self._peel_pass(slot, job)
        self.gl.ctx.depth_func = "<"
        return jobs

    def slot(self, index: int) -> _Scratch:
        return self._slots[index]

    def slot_textures(self, slot: int) -> moderngl.Texture:
        """The address map of a slot of the last hit (for the debug view)."""
        return self._slots[slot].address

    def release(self) -> None:
        release(*self._points.values())
        for slot in self._slots:
            slot.release()

    # -- pass 1 --------------------------------------------------------------------------------
    def _plan(
        self,
        target: CarveBody,
        tool: CarveBody,
        contact: ContactFrame,
        target_depth: float,
        tool_depth: float,
    ) -> list[CarveJob]:
        """The directions of a hit with a positive finite depth: the target dented by the tool,
        then the tool by the target (moving the other way). Bad contact frames give none."""
        direction = np.asarray(contact.direction, dtype=np.float64)
        direction = direction / max(float(np.linalg.norm(direction)), 1e-30)
        if not np.all(np.isfinite(direction)) or not np.all(np.isfinite(contact.point)):
            return []
        jobs: list[CarveJob] = []
        if _positive(target_depth):
            jobs.append(
                self._job(target, tool, ContactFrame(contact.point, direction), target_depth)
            )
        if _positive(tool_depth):
            jobs.append(
                self._job(tool, target, ContactFrame(contact.point, -direction), tool_depth)
            )
        return jobs

    def _job(
        self, target: CarveBody, tool: CarveBody, contact: ContactFrame, depth: float
    ) -> CarveJob:
        advanced = np.array(tool.model, dtype=np.float64)
        advanced[:3, 3] += contact.direction * depth  # the tool advances by the dent depth
        camera = collision_camera(
            target.gpu_mesh.mesh,
            target.model,
            target.maps.size,
            advanced[:3, 3],
            tool.radius(),
            contact,
            self.max_resolution,
        )
        return CarveJob(target, tool, advanced, camera)

    # -- passes 2 and 3 ------------------------------------------------------------------------
    def _address_pass(self, slot: _Scratch, job: CarveJob) -> None:
        ctx = self.gl.ctx
        w, h = job.camera.resolution
        slot.address_fbo.use()
        ctx.viewport = (0, 0, w, h)
        slot.address_fbo.clear(-1.0, -1.0, 0.0, 0.0, depth=1.0, viewport=(0, 0, w, h))
        ctx.disable(moderngl.BLEND)
        ctx.enable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.front_face = "ccw"
        ctx.cull_face = "back"
        ctx.depth_func = "<"
        prog = self._address
        _set_camera(prog, job.camera)
        _set_model(prog, job.target.model)
        job.target.maps.height.use(0)
        prog["u_height"] = 0
        job.target.gpu_mesh.vao(prog).render(moderngl.TRIANGLES)

    def _peel_pass(self, slot: _Scratch, job: CarveJob) -> None:
        ctx = self.gl.ctx
        w, h = job.camera.resolution
        slot.peel_clear_fbo.use()
        slot.peel_clear_fbo.clear(NO_CHANGE, 0.0, 0.0, 0.0, viewport=(0, 0, w, h))
        slot.peel_fbo.use()
        ctx.viewport = (0, 0, w, h)
        ctx.enable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.cull_face = "front"  # keep the tool's back faces
        ctx.depth_func = ">"  # farther than the target's surface
        prog = self._peel
        _set_camera(prog, job.camera)
        _set_model(prog, job.tool_model)
        job.tool.maps.height.use(0)
        slot.address.use(1)
        slot.depth_a.use(2)
        prog["u_height"] = 0
        prog["u_address"] = 1
        prog["u_depth_a"] = 2
        prog["u_min_height"] = -job.target.maps.max_dent_depth
        job.tool.gpu_mesh.vao(prog).render(moderngl.TRIANGLES)

    # -- passes 4 and 5 ------------------------------------------------------------------------
    def _footprint_pass(
        self,
        slot: _Scratch,
        job: CarveJob,
        prog: moderngl.Program,
        fbo: moderngl.Framebuffer,
        blend_min: bool,
    ) -> None:
        ctx = self.gl.ctx
        maps = job.target.maps
        fbo.use()
        ctx.viewport = (0, 0, *maps.size)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.PROGRAM_POINT_SIZE)
        if blend_min:
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.ONE, moderngl.ONE
            ctx.blend_equation = moderngl.MIN
        else:
            ctx.disable(moderngl.BLEND)
        slot.address.use(0)
        slot.new_height.use(1)
        maps.mask.use(2)
        set_uniform(prog, "u_address", 0)
        set_uniform(prog, "u_new_height", 1)
        set_uniform(prog, "u_mask", 2)
        set_uniform(prog, "u_width", job.camera.resolution[0])
        set_uniform(prog, "u_rows", job.camera.resolution[1])
        if blend_min:
            set_uniform(prog, "u_point_size", 1.0)
            set_uniform(prog, "u_min_height", -maps.max_dent_depth)
        else:
            maps.height.use(3)
            set_uniform(prog, "u_height", 3)
            set_uniform(prog, "u_point_size", 3.0)
            set_uniform(prog, "u_texel_metres", maps.texel_metres)
            set_uniform(prog, "u_whole_map", False)
        w, h = job.camera.resolution
        self._points[id(prog)].render(moderngl.POINTS, vertices=w * h)


def _positive(value: float) -> bool:
    return bool(np.isfinite(value) and value > 0.0)


def _set_camera(prog: moderngl.Program, cam: CollisionCamera) -> None:
    prog["u_eye"] = tuple(cam.eye)
    prog["u_right"] = tuple(cam.right)
    prog["u_up"] = tuple(cam.up)
    prog["u_forward"] = tuple(cam.forward)
    prog["u_half_extent"] = cam.half_extent
    prog["u_depth_range"] = cam.depth_range


def _set_model(prog: moderngl.Program, model: NDArray[np.float64]) -> None:
    m = np.asarray(model, dtype=np.float64)
    normal_matrix = np.linalg.inv(m[:3, :3]).T
    prog["u_model"].write(m.T.astype("f4").tobytes())  # column-major
    prog["u_normal_matrix"].write(normal_matrix.T.astype("f4").tobytes())
