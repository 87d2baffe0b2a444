"""The five GPU passes of the carve (docs/carve.md), for a target dented by a tool and, when the
tool is deformable too, the tool dented by the target. No GPU->CPU reads; the work of one hit
follows its footprint (the collision camera's pixels and the texels under them), never the size
of the maps."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field

import moderngl
import numpy as np
from numpy.typing import NDArray

from dentdemo.carve.camera import BodyPose, CollisionCamera, ContactFrame, collision_camera
from dentdemo.carve.constants import NO_FRONT, NO_SURFACE, NO_TOOL, shader_defines
from dentdemo.carve.surface import GpuMesh, SurfaceMaps
from dentdemo.carve.texel_passes import (
    camera_uniforms,
    clip_uniforms,
    model_uniforms,
    rebuild_normals,
    swept_uniforms,
    texture_space_passes,
)
from dentdemo.gl.context import GLContext, release
from dentdemo.gl.passes import Blend, Pass, PassState
from dentdemo.gl.shaders import program
from dentdemo.gl.state import preserved


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

    def pose(self, model: NDArray[np.float64] | None = None) -> BodyPose:
        m = self.model if model is None else model
        return BodyPose(
            self.gpu_mesh.mesh,
            np.asarray(m, dtype=np.float64),
            self.maps.max_height,
            self.maps.max_dent_depth,
            min(self.maps.texel_metres),
        )


@dataclass(frozen=True)
class CarveJob:
    """One direction of a hit: `target` dented by `tool` posed at `tool_model`."""

    target: CarveBody
    tool: CarveBody
    tool_model: NDArray[np.float64]
    camera: CollisionCamera
    #: Uniforms every pass of this direction shares: the camera with the target's pose and solid,
    #: and with the tool's (made once per hit).
    target_uniforms: dict[str, object]
    tool_uniforms: dict[str, object]


class _Scratch:
    """Per-direction collision-camera buffers, allocated once at the largest resolution; each hit
    uses (and clears) only its own viewport, so it costs its footprint."""

    def __init__(self, ctx: moderngl.Context, size: int) -> None:
        self.address = ctx.texture((size, size), 4, dtype="f4")
        # (back view depth m, coverage, -, front view depth m): pass 3.
        self.tool_depth = ctx.texture((size, size), 4, dtype="f4")
        self.depth = ctx.depth_texture((size, size))
        self.address.filter = (moderngl.NEAREST, moderngl.NEAREST)
        # Pass 4 interpolates the tool's depth between pixels with the sampler; pass 3 clears only
        # its own viewport, so the border of what is in use is never sampled across.
        self.tool_depth.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.address_fbo = ctx.framebuffer([self.address], self.depth)
        self.peel_fbo = ctx.framebuffer([self.tool_depth], self.depth)

    def release(self) -> None:
        release(self.address_fbo, self.peel_fbo, self.address, self.tool_depth, self.depth)


#: Pass 3's blend: the farthest back face and the coverage (red, green: MAX), the nearest front
#: face (alpha: MIN); order-independent, so the result is the same whatever order faces come in.
_PEEL_BLEND = Blend(
    moderngl.ONE, moderngl.ONE, moderngl.ONE, moderngl.ONE, moderngl.MAX, moderngl.MIN
)
#: Passes 2 and 3: fixed-function state and the textures each samples.
_SURFACE_PASSES = {
    # The target's front faces from the slab's near side on (one clip distance: u_near_clip).
    "address": (
        PassState(depth_test=True, depth_func="<", cull="back", clip_distances=1),
        ("u_height", "u_tool"),
    ),
    "peel": (PassState(blend=_PEEL_BLEND), ("u_height",)),  # the tool's faces, both sides
}


class Carver:
    """Carves dents into SurfaceMaps. One per GL context."""

    def __init__(self, gl: GLContext, max_resolution: int = 1023) -> None:
        self.gl = gl
        self.max_resolution = max_resolution
        self._slots = [_Scratch(gl.ctx, max_resolution) for _ in range(2)]
        #: Passes 2 and 3 by (name, whether the body drawn is a swept solid: SWEPT).
        self._surface = {
            (name, swept): Pass(
                name,
                program(
                    gl.cache,
                    gl.ctx,
                    "carve/surface.vert",
                    f"carve/{name}.frag",
                    defines=shader_defines(SWEPT=int(swept)),
                ),
                state,
                samplers,
            )
            for name, (state, samplers) in _SURFACE_PASSES.items()
            for swept in (False, True)
        }
        self._texel = texture_space_passes(gl)
        #: The cameras of the last hit (for the address-map debug view and tests).
        self.last_jobs: list[CarveJob] = []
        #: Wraps each pass when set (the benchmark's GPU timer queries); names as in docs/carve.md.
        self.pass_timer: Callable[[str], AbstractContextManager] | None = None
        #: Bound the camera by whole bodies instead of the footprint (tests of the bound only).
        self.loose_camera = False
        #: Per-triangle lists of what each pass draws on a software rasteriser, whose vertex work
        #: is CPU work; whole clusters on a GPU, where planning is the cost of a hit.
        self.exact_lists = gl.software

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
        jobs = self.plan(target, tool, contact, target_depth, tool_depth)
        if jobs:
            with preserved(self.gl.ctx):  # the host's GL state, as it left it
                self._run(jobs)
            self.last_jobs = jobs
        return jobs

    def _run(self, jobs: list[CarveJob]) -> None:
        """Passes 3, 2, 4 and 5 of every direction (pass 2 reads pass 3's front faces)."""
        with self._timed("peel"):
            for slot, job in zip(self._slots, jobs, strict=False):
                self._peel_pass(slot, job)
        with self._timed("address"):
            for slot, job in zip(self._slots, jobs, strict=False):
                self._address_pass(slot, job)
        with self._timed("gather"):
            for slot, job in zip(self._slots, jobs, strict=False):
                self._gather_pass(slot, job)
        with self._timed("normals"):
            for job in jobs:
                target = job.target
                rebuild_normals(
                    self.gl,
                    target.gpu_mesh,
                    target.maps,
                    target.model,
                    job.camera,
                    self._texel,
                    job.target_uniforms,
                )

    def measure_passes(
        self,
        target: CarveBody,
        tool: CarveBody,
        contact: ContactFrame,
        target_depth: float,
        tool_depth: float = 0.0,
    ) -> list[CarveJob]:
        """Passes 1-3 only, for the CPU reference path (which then reads their buffers back)."""
        jobs = self.plan(target, tool, contact, target_depth, tool_depth)
        with preserved(self.gl.ctx):
            for slot, job in zip(self._slots, jobs, strict=False):
                self._peel_pass(slot, job)
                self._address_pass(slot, job)
        return jobs

    def slot(self, index: int) -> _Scratch:
        return self._slots[index]

    def slot_textures(self, slot: int) -> moderngl.Texture:
        """The address map of a slot of the last hit (for the debug view)."""
        return self._slots[slot].address

    def release(self) -> None:
        for slot in self._slots:
            slot.release()

    def _timed(self, name: str) -> AbstractContextManager:
        return self.pass_timer(name) if self.pass_timer else contextlib.nullcontext()

    # -- pass 1 --------------------------------------------------------------------------------
    def plan(
        self,
        target: CarveBody,
        tool: CarveBody,
        contact: ContactFrame,
        target_depth: float,
        tool_depth: float,
    ) -> list[CarveJob]:
        """The directions of a hit with a positive finite depth: the target dented by the tool,
        then the tool by the target (moving the other way). Bad contact frames and presses whose
        bodies cannot meet give none."""
        direction = np.asarray(contact.direction, dtype=np.float64)
        norm = float(np.linalg.norm(direction))
        point = np.asarray(contact.point, dtype=np.float64)
        if not (np.isfinite(norm) and norm > 1e-12) or not np.all(np.isfinite(point)):
            return []
        direction = direction / norm
        jobs: list[CarveJob] = []
        for body, other, frame, depth in (
            (target, tool, ContactFrame(point, direction), target_depth),
            (tool, target, ContactFrame(point, -direction), tool_depth),
        ):
            if np.isfinite(depth) and depth > 0.0:
                job = self._job(body, other, frame, float(depth))
                if job is not None:
                    jobs.append(job)
        return jobs

    def _job(
        self, target: CarveBody, tool: CarveBody, contact: ContactFrame, depth: float
    ) -> CarveJob | None:
        advanced = np.array(tool.model, dtype=np.float64)
        advanced[:3, 3] += contact.direction * depth  # the tool advances by the dent depth
        camera = collision_camera(
            target.pose(),
            tool.pose(advanced),
            target.maps.size,
            contact,
            self.max_resolution,
            loose=self.loose_camera,
            exact_lists=self.exact_lists,
            advance=depth,
        )
        if camera is None:
            return None
        view = camera_uniforms(camera)
        return CarveJob(
            target,
            tool,
            advanced,
            camera,
            {
                **view,
                **model_uniforms(target.model),
                **swept_uniforms(target.gpu_mesh.mesh, target.model),
                "u_near_clip": camera.ring_slab[0],
                "u_advance": depth,
            },
            {**view, **model_uniforms(advanced), **swept_uniforms(tool.gpu_mesh.mesh, advanced)},
        )

    # -- passes 2 and 3 ------------------------------------------------------------------------
    def _address_pass(self, slot: _Scratch, job: CarveJob) -> None:
        clear = (NO_SURFACE, NO_SURFACE, 0.0, 0.0, 1.0)  # (u, v, ..., depth: the far plane)
        self._camera_pass("address", slot.address_fbo, clear, job, job.target, (slot.tool_depth,))

    def _peel_pass(self, slot: _Scratch, job: CarveJob) -> None:
        clear = (NO_TOOL, NO_TOOL, 0.0, NO_FRONT, 1.0)  # (back, coverage, -, front; no depth test)
        self._camera_pass("peel", slot.peel_fbo, clear, job, job.tool)

    def _camera_pass(
        self,
        name: str,
        fbo: moderngl.Framebuffer,
        clear: tuple[float, float, float, float, float],
        job: CarveJob,
        body: CarveBody,
        inputs: tuple[moderngl.Texture, ...] = (),
    ) -> None:
        """Passes 2 and 3: `body` (the target or the tool) drawn by the collision camera into its
        own viewport of `fbo`, cleared first to `clear` (colour, then depth), sampling its own
        height map and `inputs`."""
        view = (0, 0, *job.camera.resolution)
        fbo.clear(*clear[:4], depth=clear[4], viewport=view)
        target = body is job.target
        triangles = job.camera.target_view if target else job.camera.tool_view
        uniforms = job.target_uniforms if target else job.tool_uniforms
        self._surface[name, bool(uniforms["u_swept"])].run(
            self.gl.ctx,
            fbo,
            view,
            body.gpu_mesh.drawer(triangles, name),
            (body.maps.height, *inputs),
            uniforms,
        )

    # -- pass 4 --------------------------------------------------------------------------------
    def _gather_pass(self, slot: _Scratch, job: CarveJob) -> None:
        maps = job.target.maps
        cam = job.camera
        px, py = cam.pixel_metres
        uniforms = {
            **job.target_uniforms,
            **clip_uniforms(cam, maps, cam.slab),
            "u_min_height": -maps.max_dent_depth,
            "u_ceiling": maps.max_height,
            "u_pixel_diagonal": float(np.hypot(px, py)),
        }
        for gutter, triangles in ((0, cam.target_texels), (1, cam.target_gutter)):
            if len(triangles) == 0:
                continue
            gather = self._texel["gather", gutter, bool(uniforms["u_swept"])]
            gather.run(
                self.gl.ctx,
                maps.height_fbo,
                (0, 0, *maps.size),
                job.target.gpu_mesh.drawer(triangles, f"texels{gutter}"),
                (slot.address, slot.tool_depth, maps.mask),
                uniforms,
            )
