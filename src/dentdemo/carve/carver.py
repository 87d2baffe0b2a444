"""The five GPU passes of the carve (docs/carve.md), for a target dented by a tool and, when the
tool is deformable too, the tool dented by the target. No GPU->CPU reads; the work of one hit
follows its footprint (the collision camera's pixels and the texels under them), never the size
of the maps."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass, field, replace
from functools import partial
from itertools import islice
from typing import TYPE_CHECKING, NamedTuple

import moderngl
import numpy as np
from numpy.typing import NDArray

from dentdemo.carve.camera import (
    BodyPose,
    CollisionCamera,
    ContactFrame,
    DraftRequest,
    camera_drafts,
    collision_cameras,
)
from dentdemo.carve.constants import (
    NO_FRONT,
    NO_SURFACE,
    NO_TOOL,
    SUBSET_TRIANGLES,
    shader_defines,
)
from dentdemo.carve.jobs import RECT_ENTRIES, JobTable, RectTable, job_entries
from dentdemo.carve.linear import inverse3
from dentdemo.carve.params import (
    Advance,
    Draw,
    Gather,
    Quad,
    Rect,
    Subset,
    SurfaceUniforms,
    check_program,
)
from dentdemo.carve.texel_passes import (
    CHART,
    CLIP_DISTANCES,
    GUTTER,
    RECT,
    VARIANT_KEYS,
    camera_uniforms,
    clip_uniforms,
    cube_grid,
    is_swept,
    pose_uniforms,
    quad_kind,
    sphere_atlas_defines,
    texture_space_passes,
)
from dentdemo.carve.undo import footprint_boxes
from dentdemo.gl.context import GLContext, release
from dentdemo.gl.library import flush
from dentdemo.gl.passes import Blend, HeldState, Pass, PassState, held_state, neutral, shared_batch
from dentdemo.gl.shaders import program
from dentdemo.gl.state import preserved
from dentdemo.gpu.maps import SurfaceMaps
from dentdemo.gpu.mesh import GpuMesh, upload

if TYPE_CHECKING:
    from dentdemo.carve.undo import UndoLog
    from dentdemo.mesh.mesh import Mesh


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
    #: Whether some normal of the texels pass 4 draws is not the press direction: then pass 4
    #: finds each texel's exit from the swept solid along its normal (its EXIT variant).
    oblique: bool = True
    #: Whether the target is a built-in shape, whose surface hides none of itself from the
    #: camera (a convex solid, or a plate's flat face): pass 4 then needs no address map and
    #: pass 2 is left out (its CONVEX variant; docs/carve.md, "Pass 2").
    convex: bool = False
    #: The camera's lower-left pixel in the scratch atlas (set when its batch is packed).
    tile: tuple[int, int] = (0, 0)

    @property
    def viewport(self) -> tuple[int, int, int, int]:
        return (*self.tile, *self.camera.resolution)

    def placed(self, tile: tuple[int, int]) -> CarveJob:
        """This job with its camera at `tile` of the atlas."""
        at = {"u_tile": tile}
        return replace(
            self,
            tile=tile,
            target_uniforms={**self.target_uniforms, **at},
            tool_uniforms={**self.tool_uniforms, **at},
        )


class Press(NamedTuple):
    """One hit for `Carver.carve_many` (a plain 5-tuple in this order does as well)."""

    target: CarveBody
    #: Posed at first touch.
    tool: CarveBody
    contact: ContactFrame
    #: The target's dent depth, metres.
    depth: float
    #: The tool's dent depth, metres.
    tool_depth: float = 0.0


#: Pixels a collision camera has at most a side (beyond, its pixels grow).
MAX_RESOLUTION = 1023
#: Bytes a pixel of the cameras' atlas takes: the address map RGBA32F (16), the tool's extent
#: RGBA32F (16), depth (4).
ATLAS_BYTES_PER_PIXEL = 16 + 16 + 4


def atlas_size(max_resolution: int) -> tuple[int, int]:
    """The cameras' atlas for cameras of at most `max_resolution` pixels a side: two of the
    largest side by side (the memory of one hit's two directions), or many small ones; a power
    of two each way (pass 4's sampling)."""
    width = 1 << (2 * max_resolution + 1).bit_length()
    return width, width // 2


class _Scratch:
    """The collision cameras' buffers: one atlas, allocated once, in which each direction of a
    batch has its own tile (shelf-packed); a batch uses (and clears) only the tiles' bounding
    box, so it costs its footprints."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int]) -> None:
        self.size = size
        self.address = ctx.texture(size, 4, dtype="f4")
        # (back view depth m, coverage, -, front view depth m): pass 3.
        self.tool_depth = ctx.texture(size, 4, dtype="f4")
        self.depth = ctx.depth_texture(size)
        self.address.filter = (moderngl.NEAREST, moderngl.NEAREST)
        # Pass 4 interpolates the tool's depth between pixels with the sampler (within a tile:
        # it blends only where the four pixels around a point are the tile's own).
        self.tool_depth.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.address_fbo = ctx.framebuffer([self.address], self.depth)
        self.peel_fbo = ctx.framebuffer([self.tool_depth], self.depth)

    def release(self) -> None:
        release(self.address_fbo, self.peel_fbo, self.address, self.tool_depth, self.depth)

    def pack(self, hits: list[list[CarveJob]]) -> Iterator[list[CarveJob]]:
        """The directions of `hits` placed in tiles, as consecutive batches that each fit the
        atlas (a hit's directions stay in one batch: both read the heights from before it)."""
        batch: list[CarveJob] = []
        cursor = (0, 0, 0)
        for hit in hits:
            placed = self._place(hit, cursor)
            if placed is None and batch:  # full: this hit starts the next batch
                yield batch
                batch, cursor = [], (0, 0, 0)
                placed = self._place(hit, cursor)
            if placed is None:
                raise ValueError("a hit's cameras do not fit the empty atlas")
            jobs, cursor = placed
            batch += jobs
        if batch:
            yield batch

    def _place(
        self, hit: list[CarveJob], cursor: tuple[int, int, int]
    ) -> tuple[list[CarveJob], tuple[int, int, int]] | None:
        """`hit`'s cameras as tiles from `cursor` (x, y, the shelf's height) on: shelves left to
        right, bottom to top, one pixel apart; None where they do not fit."""
        width, height = self.size
        x, y, shelf = cursor
        placed = []
        for job in hit:
            w, h = job.camera.resolution
            if x + w > width:
                x, y, shelf = 0, y + shelf + 1, 0
            if y + h > height:
                return None
            placed.append(job.placed((x, y)))
            x, shelf = x + w + 1, max(shelf, h)
        return placed, (x, y, shelf)


#: A built-in sphere's chart texels are drawn as rectangles where its footprint's triangles hold
#: at most this many texels of their boxes each: finer, the triangles' setup costs more than the
#: rectangles' idle texels (docs/carve.md, "Texel rectangles"; the crossover was measured on
#: llvmpipe).
RECT_TEXELS_PER_TRIANGLE = 3.0


def _texel_draws(
    job: CarveJob, rects: float, quad: Callable[[moderngl.Program], None]
) -> Iterator[tuple[int, Callable[[moderngl.Program], None], tuple[int, int, int, int] | None]]:
    """Passes 4 and 5's draws of `job`'s target: (how it covers texels, draw, its rectangle)
    for its triangles in the footprint (CHART) and those of them on a chart border (GUTTER),
    where there are any. A built-in sphere's chart texels are drawn instead as one rectangle
    (`quad`, util/rect.vert; x, y, width, height in texels) per chart the footprint's triangles
    meet, their texel bounding box there (RECT), where those triangles hold at most `rects`
    texels of the boxes each."""
    cam, gpu_mesh = job.camera, job.target.gpu_mesh
    count = len(cam.target_texels)
    if not count:
        return
    boxes = footprint_boxes(job) if rects > 0 and cube_grid(gpu_mesh.mesh) else []
    area = sum((x1 - x0) * (y1 - y0) for x0, y0, x1, y1 in boxes)
    if boxes and area <= rects * count:
        for x0, y0, x1, y1 in boxes:
            yield RECT, quad, (x0, y0, x1 - x0, y1 - y0)
    else:
        yield CHART, gpu_mesh.drawer(cam.target_texels, "texels0"), None
    if len(cam.target_gutter):
        yield GUTTER, gpu_mesh.drawer(cam.target_gutter, "texels1"), None


#: What a draw of passes 4 and 5 costs, in triangles of its list (llvmpipe's main thread shades
#: the vertices and clips the triangles of every instance): the jobs of one map whose lists
#: differ are one instanced draw of the union of their lists where that costs no more than a
#: draw each (docs/carve.md, "Batches").
UNION_TRIANGLES_PER_DRAW = 128.0


def _instanced(
    jobs: list[tuple[int, CarveJob]], draws: list[list[tuple]], per_draw: float, per_range: int
) -> tuple[list[tuple[int, CarveJob]], list[list[tuple]]]:
    """`jobs` (each with its place in the batch, one map's together) and their `_texel_draws`,
    the triangle-list draws of consecutive jobs that dent one map under one variant (their
    entries in one range of the job table, no rectangles) made one instanced draw (instance i:
    entry k + i) where their lists are the same, or where drawing the union of their lists for
    each costs no more than a draw each (`per_draw` triangles a draw; 0: the same lists only).
    Each instance clips to its own camera and slab, so another job's triangles add only texels
    beyond its footprint's margin, which the tool does not reach and whose normals are rebuilt
    from unchanged heights (`test_a_union_of_lists_dents_as_each_its_own`)."""
    out_jobs: list[tuple[int, CarveJob]] = []
    out_draws: list[list[tuple]] = []

    def shape(i: int) -> tuple | None:
        (k, job), texel_draws = jobs[i], draws[i]
        if any(rect is not None for _, _, rect in texel_draws):
            return None  # rectangles: instanced already
        swept = job.target_uniforms["u_swept"]
        kinds = tuple(kind for kind, _, _ in texel_draws)
        return (id(job.target.maps), swept, job.oblique, job.convex, kinds, k // per_range)

    def emit(members: list[int], lists: Sequence[NDArray[np.int64]]) -> None:
        k, job = jobs[members[0]]
        merged = draws[members[0]]
        if len(members) > 1:
            gpu_mesh = job.target.gpu_mesh
            merged = [
                (kind, gpu_mesh.drawer(triangles, draw.subset, len(members)), None)
                for (kind, draw, _), triangles in zip(merged, lists, strict=True)
            ]
        out_jobs.append((k, job))
        out_draws.append(merged)

    def close(run: list[int]) -> None:
        if len(run) == 1:
            emit(run, ())
            return
        lists = [[draw.triangles for _, draw, _ in draws[i]] for i in run]
        same: list[list[int]] = []  # positions in `run` of consecutive jobs with the same lists
        for at, mine in enumerate(lists):
            first = lists[same[-1][0]] if same else None
            if first is not None and all(map(np.array_equal, first, mine)):
                same[-1].append(at)
            else:
                same.append([at])
        if len(same) > 1 and per_draw > 0:
            unions = [np.unique(np.concatenate(parts)) for parts in zip(*lists, strict=True)]
            drawn = len(run) * sum(len(union) for union in unions)
            own = sum(len(triangles) for mine in lists for triangles in mine)
            if drawn <= own + per_draw * (len(same) - 1) * len(unions):
                emit(run, unions)
                return
        for members in same:
            emit([run[at] for at in members], lists[members[0]])

    shapes = [shape(i) for i in range(len(jobs))]
    run: list[int] = []  # consecutive jobs that may share draws
    for i, (k, _) in enumerate(jobs):
        joins = run and k == jobs[run[-1]][0] + 1 and shapes[i] is not None
        if not (joins and shapes[i] == shapes[run[-1]]):
            if run:
                close(run)
            run = []
        run.append(i)
    if run:
        close(run)
    return out_jobs, out_draws


def _oblique(
    target: CarveBody, camera: CollisionCamera, shared: NDArray[np.float64] | None
) -> bool:
    """Whether any vertex normal of the triangles pass 4 draws (or a swept solid's surface) is
    not the press direction reversed, to float rounding. `shared`: a flat target's one normal
    in the world (`Carver._shared_normal`), or None for another target."""
    mesh = target.gpu_mesh.mesh
    if is_swept(mesh):
        return True  # a sphere or capsule's own normals
    if len(camera.target_texels) == 0:
        return False
    normals = shared
    if normals is None:
        local = mesh.normals[np.unique(mesh.indices[camera.target_texels].ravel())]
        normals = _world_normals(local, target.model)
    return bool((normals @ -camera.forward < 1.0 - 1e-6).any())


def _world_normals(local: NDArray, model: NDArray[np.float64]) -> NDArray[np.float64]:
    """Local normals (rows) in the world of a body posed at `model`, unit length."""
    m = np.asarray(model, dtype=np.float64)[:3, :3]
    normals = local.astype(np.float64) @ inverse3(m)  # world, by rows
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return normals


def _target_entry(job: CarveJob) -> dict[str, object]:
    """`job`'s target's entry of the batch's job table (passes 2, 4 and 5: the camera, the
    target's pose and solid, the press, the clip box and both slabs, the gather's bounds); its
    tool's (pass 3) is `tool_uniforms` (the camera, the tool's pose and solid)."""
    cam, maps = job.camera, job.target.maps
    px, py = cam.pixel_metres
    bounds = Gather(
        u_min_height=-maps.max_dent_depth,
        u_ceiling=maps.max_height,
        u_pixel_diagonal=math.hypot(px, py),
    )
    return {**job.target_uniforms, **clip_uniforms(cam, maps).values(), **bounds.values()}


@contextlib.contextmanager
def _from_neutral(ctx: moderngl.Context) -> Iterator[None]:
    """`preserved` without the host's state: the body starts from `neutral` state, and what
    it leaves stays (its passes end in `neutral` state; the last framebuffer it bound stays
    bound, as moderngl records)."""
    neutral(ctx)
    yield


class _Run(NamedTuple):
    """Pass 2 or 3's draw of consecutive entries of the job table (`Carver._camera_runs`)."""

    pass_: Pass
    #: Its first entry; instance i reads entry first + i.
    first: int
    #: (k, job, triangle list or None, textures) of each instance.
    items: list[tuple]
    draw: Callable[[moderngl.Program], None]
    #: Each instance's `Subset` bits (the union's triangles that are another's), or None.
    skips: list[tuple[int, int, int, int] | None]
    #: The tile of a draw with its tile as the viewport; None: the atlas (placed in its tile
    #: by the vertex stage).
    viewport: tuple[int, int, int, int] | None


class _Joining:
    """The run `Carver._camera_runs` is building: whether the next item may be drawn as one
    more instance of it (the next entry, in the range of the one before it, sampling the same
    map; a mesh's list the same as the run's, or their union within SUBSET_TRIANGLES)."""

    def __init__(self, entry: int, item: tuple, per_range: int) -> None:
        self.members: list[tuple] = [(entry, item)]
        self.per_range = per_range  # entries a range of the job table holds
        self.same = True  # every list of the run is the first's
        first = item[2]
        small = first is not None and len(first) <= SUBSET_TRIANGLES
        self.union: set[int] | None = set(first.tolist()) if small else None

    def join(self, entry: int, item: tuple) -> bool:
        """Add `item` where it may be drawn with the run; False (and nothing added) otherwise."""
        last_entry, last = self.members[-1]
        next_range = entry % self.per_range == 0
        if entry != last_entry + 1 or next_range or item[3][0] is not last[3][0]:
            return False
        mine, first = item[2], self.members[0][1]
        if mine is not None:  # a mesh: the same mesh, and the same list or a small union
            if item[1].tool.gpu_mesh is not first[1].tool.gpu_mesh:
                return False
            if not (self.same and np.array_equal(mine, first[2])):
                union = None if self.union is None else self.union.union(mine.tolist())
                if union is None or len(union) > SUBSET_TRIANGLES:
                    return False
                self.union, self.same = union, False
        self.members.append((entry, item))
        return True


def _skip_bits(mine: NDArray[np.int64], count: int) -> tuple[int, int, int, int]:
    """`Subset`'s bits: set for each of `count` triangles of a list but those at `mine`."""
    skip = np.ones(SUBSET_TRIANGLES, dtype=bool)
    skip[count:] = False
    skip[mine] = False
    words = np.packbits(skip, bitorder="little").view("<i4")
    return (int(words[0]), int(words[1]), int(words[2]), int(words[3]))


#: Poses whose uniforms the carver keeps (a burst's bodies; cleared when full).
POSES_KEPT = 256

#: Passes 2 and 3's variants that draw a swept solid as one quad.
_QUADS = ((True, Quad.SPHERE), (True, Quad.CAPSULE))

#: Pass 3's blend: the farthest back face and the coverage (red, green: MAX), the nearest front
#: face (alpha: MIN); order-independent, so the result is the same whatever order faces come in.
_PEEL_BLEND = Blend(
    moderngl.ONE, moderngl.ONE, moderngl.ONE, moderngl.ONE, moderngl.MAX, moderngl.MIN
)
#: Passes 2 and 3: fixed-function state and the textures each samples. Every carve pass enables
#: the same clip distances (unused ones are 1), so none is switched between passes.
_SURFACE_PASSES = {
    # The target's front faces from the slab's near side on (clip distance 0: u_near_clip).
    "address": (
        PassState(depth_test=True, depth_func="<", cull="back", clip_distances=CLIP_DISTANCES),
        ("u_height", "u_tool"),
    ),
    # The tool's faces, both sides (a mesh's clipped to its tile: TILED).
    "peel": (PassState(blend=_PEEL_BLEND, clip_distances=CLIP_DISTANCES), ("u_height",)),
}


@dataclass(frozen=True)
class CarverOptions:
    """How a `Carver` carves, fixed when it is made."""

    #: Pixels a collision camera has at most a side (beyond, its pixels grow); the scratch
    #: atlas holds two of the largest side by side.
    max_resolution: int = MAX_RESOLUTION
    #: Give the host its GL state back after each batch (`gl.state.preserved`). False for
    #: the sandbox, which owns its context and whose every pass sets the state it draws
    #: with: the batch then starts from `neutral` state and leaves it, and the capture and
    #: restore of the host's state are saved.
    keep_host_state: bool = True
    #: Snapshots each batch's footprints before it is carved (carve/undo.py), or None.
    undo_log: UndoLog | None = None
    #: Draw pass 2 for every target, also for convex ones that pass 4 does not need it for
    #: (the address-map debug view).
    address_every_target: bool = False
    #: Per-triangle lists of what each pass draws (True), or whole clusters (False); None: per
    #: triangle on a software rasteriser, whose vertex work is CPU work, whole clusters on a
    #: GPU, where planning is the cost of a hit.
    exact_lists: bool | None = None
    #: Wraps each pass when set (the benchmark's GPU timer queries); names as in docs/carve.md.
    pass_timer: Callable[[str], AbstractContextManager] | None = None


@dataclass(frozen=True)
class _Switches:
    """Other ways of drawing the same dents, which the tests compare with the usual ones (not
    an option: each gives what the default gives, to rounding, at another cost)."""

    #: Draw built-in spheres and capsules in passes 2 and 3 as one quad each (False: their
    #: facets).
    swept_quads: bool = True
    #: Draw a built-in sphere's chart texels in passes 4 and 5 as rectangles of texels, each
    #: finding its facet from the sphere's atlas, where its footprint's triangles hold at most
    #: this many texels of their boxes each (0: never; inf: always).
    rect_texels_per_triangle: float = RECT_TEXELS_PER_TRIANGLE
    #: Bound the camera by whole bodies instead of the footprint (tests of the bound).
    loose_camera: bool = False
    #: Draw the lists of one map's jobs as one instanced draw of their union where that costs
    #: at most this many triangles a draw saved (0: only jobs whose lists are the same).
    union_triangles_per_draw: float = UNION_TRIANGLES_PER_DRAW
    #: Place a mesh tool in its tile in pass 3's vertex stage (surface.vert TILED 1), so that the
    #: jobs that draw one tool mesh are one instanced draw (False: a draw each, with its tile
    #: as the viewport).
    tiled_peel: bool = True


class Carver:
    """Carves dents into SurfaceMaps. One per GL context (or more: each has its scratch atlas),
    configured once by its `CarverOptions`."""

    def __init__(
        self,
        gl: GLContext,
        options: CarverOptions = CarverOptions(),
        *,
        _switches: _Switches = _Switches(),
    ) -> None:
        self.gl = gl
        self._options = options
        self._switches = _switches
        self._exact_lists = gl.software if options.exact_lists is None else options.exact_lists
        self.scratch = _Scratch(gl.ctx, atlas_size(options.max_resolution))
        atlas = sphere_atlas_defines()
        #: Passes 2 and 3 by (name, whether the body drawn is a swept solid: SWEPT, whether it
        #: is a sphere or capsule drawn as one quad: QUAD 1, 2); pass 3 of a mesh tool drawn
        #: instanced over jobs, each placed in its tile (TILED 1), by SWEPT.
        self._surface: dict[tuple[str, bool, Quad], Pass] = {}
        self._tiled: dict[bool, Pass] = {}
        for name, (state, samplers) in _SURFACE_PASSES.items():
            for swept, quad in ((False, Quad.NONE), (True, Quad.NONE), *_QUADS):
                mesh_peel = name == "peel" and not quad
                for tiled in (False, True) if mesh_peel and _switches.tiled_peel else (False,):
                    prog = program(
                        gl.cache,
                        gl.ctx,
                        "carve/quad.vert" if quad else "carve/surface.vert",
                        f"carve/{name}.frag",
                        "carve/peel.geom" if mesh_peel else None,
                        defines=shader_defines(
                            SWEPT=int(swept),
                            QUAD=int(quad),
                            PLANE=int(name == "peel"),
                            TILED=int(tiled),
                            JOB_ENTRIES=job_entries(gl.ctx),
                            CLIP_DISTANCES=CLIP_DISTANCES,
                            ATLAS=f"vec2{tuple(float(side) for side in self.scratch.size)}",
                            **atlas,
                        ),
                    )
                    key = (name, swept, quad)
                    check_program(prog, SurfaceUniforms, samplers, f"carve pass {key}")
                    pass_ = Pass(name, prog, state, samplers, VARIANT_KEYS)
                    if tiled:
                        self._tiled[swept] = pass_
                    else:
                        self._surface[key] = pass_
        self._quad_vaos: dict[int, moderngl.VertexArray] = {}
        self._texel = texture_space_passes(gl)
        #: The texture units the passes sample (0 .. this - 1).
        passes = (*self._surface.values(), *self._tiled.values(), *self._texel.values())
        self._units = max(len(pass_.samplers) for pass_ in passes)
        #: The job table of the batch being drawn (`_camera_stage`), and its texel rectangles.
        self._jobs = JobTable(gl.ctx)
        self._rects = RectTable(gl.ctx)
        #: The cameras of the last hit (for the address-map debug view and tests).
        self.last_jobs: list[CarveJob] = []
        #: Pose uniforms (and a flat body's world normal) by (mesh, pose) (`_posed_entry`), at
        #: most POSES_KEPT.
        self._posed: dict[
            tuple[int, bytes],
            tuple[Mesh, dict[str, object], dict[str, NDArray[np.float64] | None]],
        ] = {}
        #: The passes and kinds of map whose shader variants `warm` compiled.
        self._warmed: set[tuple] = set()

    @property
    def options(self) -> CarverOptions:
        return self._options

    @property
    def max_resolution(self) -> int:
        return self._options.max_resolution

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
        return self.carve_many([Press(target, tool, contact, target_depth, tool_depth)])

    def carve_many(
        self,
        presses: Sequence[Press],
        meanwhile: Callable[[], None] | None = None,
        *,
        meanwhile_uses_gl: bool = True,
    ) -> list[CarveJob]:
        """Every hit of `presses` in one batch (docs/carve.md, "Batches"): all of them read the
        heights from before the batch, each pass runs once for all hits, and where two hits dent
        the same texels the deeper wins (MIN). A batch whose cameras do not fit the atlas
        together is carved as consecutive batches. Returns the directions carved. `meanwhile`:
        the host's CPU work that reads no map, run once while the gathers are drawn (see
        `carve_hits`)."""
        return self.carve_hits(
            self.plan_many(presses), meanwhile, meanwhile_uses_gl=meanwhile_uses_gl
        )

    def carve_hits(
        self,
        hits: list[list[CarveJob]],
        meanwhile: Callable[[], None] | None = None,
        *,
        meanwhile_uses_gl: bool = True,
    ) -> list[CarveJob]:
        """Passes 2-5 of planned hits (each its list of directions) as one batch (see
        `carve_many`); returns the directions with their tiles. `meanwhile` runs once, after
        the first batch's gathers are handed to the rasteriser and before its normal rebuilds:
        a software rasteriser draws the gathers while the CPU does it, where pass 5's first
        draw would otherwise wait for them (on llvmpipe sampling a map the gathers wrote
        waits for all queued work). It runs (once) also when no hit has a direction. Whatever
        GL state it sets is set again after it, unless `meanwhile_uses_gl` is False: the
        caller's promise that it makes no GL call, so that the batch keeps what it knows of the
        state (the sandbox's proxies and statistics)."""
        placed: list[CarveJob] = []
        if any(hits):
            if self._options.keep_host_state:  # the host's GL state, as it left it
                # (the batches bind only the units their passes sample, and end neutral)
                kept = preserved(self.gl.ctx, self._units, leaves_neutral=True)
            else:  # or not: the app's
                kept = _from_neutral(self.gl.ctx)
            with kept:
                for batch in self.scratch.pack([hit for hit in hits if hit]):
                    first = not placed
                    self._run(
                        batch,
                        hits if first else None,
                        meanwhile if first else None,
                        meanwhile_uses_gl,
                    )
                    placed += batch
            self.last_jobs = placed
        elif meanwhile is not None:
            meanwhile()
        return placed

    def _run(
        self,
        jobs: list[CarveJob],
        record: list[list[CarveJob]] | None,
        meanwhile: Callable[[], None] | None = None,
        meanwhile_uses_gl: bool = True,
    ) -> None:
        """Passes 3, 2, 4 and 5 of every direction of a batch (pass 2 reads pass 3's front
        faces): one clear of the atlas per camera pass, the gathers and normal rebuilds grouped
        by the map they write. The undo log (if any) records `record` (every hit of the call:
        one entry, the maps before all of it) before the first gather writes; `meanwhile` (if
        any) runs once the gathers are flushed, before the normal rebuilds."""
        # One map's jobs together, so that their entries of the job table are consecutive (the
        # order changes no texel: gathers blend MIN, overlapping normal rebuilds write the same).
        jobs = sorted(jobs, key=lambda job: id(job.target.maps))
        # Each pass sets what differs from the last; the batch starts from `neutral` state.
        with held_state(self.gl.ctx, neutral=True, units=self._units) as held:
            self._camera_stage(jobs, held)  # writes the batch's job table
            # Hand passes 3 and 2 to the rasteriser now: a software one draws them while the
            # CPU goes on (the undo log's snapshot, the gathers' draws), instead of when the
            # first gather samples their result.
            flush()
            if record is not None and self._options.undo_log is not None:
                self._options.undo_log.record(record)  # binds framebuffers only
            # Each job with its place in the batch (its entries); one map's jobs are together.
            by_map = list(enumerate(jobs))
            rects, quad = self._switches.rect_texels_per_triangle, self._draw_quad
            draws = [list(_texel_draws(job, rects, quad)) for _, job in by_map]  # 4 and 5 share
            for _, job in by_map:
                job.target.gpu_mesh.ensure_thickness(job.camera.target_texels)  # gutter's in it
            per_draw = self._switches.union_triangles_per_draw
            by_map, draws = _instanced(by_map, draws, per_draw, self._jobs.per_range)
            upload(draw for texel_draws in draws for _, draw, _ in texel_draws)  # one a stream
            draws = self._rect_table(by_map, draws)
            with self._timed("gather"):
                self._gather_passes(by_map, draws, held)
            if meanwhile is not None:
                flush()  # the gathers drawn while the host's work runs
                meanwhile()
                if meanwhile_uses_gl:
                    held.forget()  # the host's work may have set state, bound textures
                    self._jobs.forget()  # or bound other uniform buffers
                    self._rects.forget()
            with self._timed("normals"):
                self._normal_passes(by_map, draws, held)
        # And pass 5 now, for the same reason: the host's CPU work after the batch then
        # overlaps it, instead of its first GL call that waits (or its glFinish) starting it.
        flush()

    def _rect_table(
        self, jobs: list[tuple[int, CarveJob]], draws: list[list[tuple]]
    ) -> list[list[tuple]]:
        """Write the batch's texel rectangles (`RectTable`), each with its job's entry in its
        range of the job table, in the order of `draws` (each job's `_texel_draws`), and give
        each RECT draw its rectangle's place in the table instead of its box."""
        rects: list[tuple[int, int, int, int, int]] = []
        placed = []
        for (k, _), texel_draws in zip(jobs, draws, strict=True):
            mine: list[tuple[int, Callable[[moderngl.Program], None], int | None]] = []
            for kind, draw, box in texel_draws:
                if box is not None:
                    rects.append((*box, k % self._jobs.per_range))
                    mine.append((kind, draw, len(rects) - 1))
                else:
                    mine.append((kind, draw, None))
            placed.append(mine)
        if rects:
            self._rects.write(rects)
        return placed

    def prepare(self, gpu_mesh: GpuMesh) -> None:
        """Make now what this carver's draws of `gpu_mesh`'s triangle lists would make at its
        first hit: its index streams and the vertex arrays of every program that may draw them
        (passes 4 and 5 as a target, pass 2 where it may hide part of itself, pass 3 as a tool
        not drawn as one quad). For a body being made (app/simulation.py): in the bench's
        sandbox, whose balls are all of other sizes, first hits otherwise made hundreds of vertex
        arrays inside the carve."""
        for _, pass_, subset in self._body_draws(gpu_mesh.mesh):
            if subset:
                gpu_mesh.vao(pass_.program, subset)

    def warm(self, gpu_mesh: GpuMesh, maps: SurfaceMaps) -> None:
        """Compile now the shader variants that this carver's first draws of a body with these
        maps would compile inside a carve: llvmpipe builds a variant of a program for each state
        it is drawn under (the formats and filters of what it samples, whether the map's sides
        are powers of two, ...) when first drawn so, a stall each time. Each program that may
        draw the body (`_body_draws`) is drawn once, under its pass's state and with the
        textures it samples then, into an empty viewport: no fragment, no texel changed. Once
        per kind of body and of map (a body like one warmed before draws nothing); the host's GL
        state is left as it was."""
        draws = list(self._body_draws(gpu_mesh.mesh))
        w, h = maps.size
        # The passes drawn, and what of the maps they sample differs between bodies (whether
        # their sides are powers of two): the same again compiles nothing new.
        key = (tuple(id(pass_) for _, pass_, _ in draws), w & (w - 1) == 0, h & (h - 1) == 0)
        if key in self._warmed:
            return
        self._warmed.add(key)
        scratch = self.scratch
        # Each pass kind's framebuffer and the textures it samples, as its draws bind them.
        targets = {
            "gather": (maps.height_fbo, (scratch.address, scratch.tool_depth, maps.mask)),
            "normals": (maps.normal_fbo, (maps.height, maps.mask)),
            "address": (scratch.address_fbo, (maps.height, scratch.tool_depth)),
            "peel": (scratch.peel_fbo, (maps.height,)),
        }
        first = np.zeros(1, dtype=np.int64)  # any triangle: the empty viewport drops it
        with preserved(self.gl.ctx):
            for table in (self._jobs, self._rects):
                table.forget()
                table.use(0)  # a table bound, whatever it holds: no fragment reads it
            for name, pass_, subset in draws:
                fbo, textures = targets[name]
                draw = gpu_mesh.drawer(first, subset) if subset else self._draw_quad
                with shared_batch(self.gl.ctx, fbo, pass_.state) as one:
                    one(pass_, (0, 0, 0, 0), draw, textures)

    def _body_draws(self, mesh: Mesh) -> Iterator[tuple[str, Pass, str]]:
        """The passes that may draw a body of `mesh`, as the carve picks their variants: (pass
        name, pass, the index stream its triangle lists go through, or "" for a quad). Passes 4
        and 5 as a target (its charts' triangles, the gutter's unless its charts fill the map,
        a built-in sphere's texel rectangles); pass 2 where it may hide part of itself (or
        every target, with `address_every_target`); pass 3 as a tool (one quad for a sphere or
        capsule with `swept_quads`)."""
        swept, convex = is_swept(mesh), mesh.bound is not None
        for kind in (CHART,) if mesh.charts_fill_map() else (CHART, GUTTER):
            subset = f"texels{kind}"
            for oblique in (True,) if swept else (False, True):  # _oblique
                yield "gather", self._texel["gather", kind, swept, oblique, convex], subset
            yield "normals", self._texel["normals", kind, False], subset
        if cube_grid(mesh):  # _texel_draws' rectangles
            yield "gather", self._texel["gather", RECT, True, True, True], ""
            yield "normals", self._texel["normals", RECT, False], ""
        quad = quad_kind(mesh) if self._switches.swept_quads else Quad.NONE
        surfaces = ["peel"] + (
            ["address"] if self._options.address_every_target or not convex else []
        )
        for name in surfaces:  # _camera_passes
            yield name, self._surface[name, swept, quad], "" if quad else name
        if not quad and self._tiled:  # pass 3 of its jobs instanced
            yield "peel", self._tiled[swept], "peel"

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
        jobs = next(self.scratch.pack([jobs]), []) if jobs else []  # one hit always fits
        with preserved(self.gl.ctx):
            self._camera_stage(jobs)
        return jobs

    def address_texture(self) -> moderngl.Texture:
        """The address maps of the last batch, each in its job's tile (the debug view)."""
        return self.scratch.address

    def release(self) -> None:
        self.scratch.release()
        self._jobs.release()
        self._rects.release()
        release(*self._quad_vaos.values())

    def _clear(
        self,
        fbo: moderngl.Framebuffer,
        clear: tuple[float, float, float, float, float],
        jobs: list[CarveJob],
    ) -> None:
        """Clear the bounding box of the jobs' tiles to `clear` (colour, then depth)."""
        if not jobs:
            return
        right = max(job.tile[0] + job.camera.resolution[0] for job in jobs)
        top = max(job.tile[1] + job.camera.resolution[1] for job in jobs)
        fbo.clear(*clear[:4], depth=clear[4], viewport=(0, 0, right, top))

    def _timed(self, name: str) -> AbstractContextManager:
        return (
            self._options.pass_timer(name) if self._options.pass_timer else contextlib.nullcontext()
        )

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
        return self.plan_many([Press(target, tool, contact, target_depth, tool_depth)])[0]

    def plan_many(self, presses: Sequence[Press]) -> list[list[CarveJob]]:
        """`plan` of each press, the triangle lists of all their cameras found together
        (`camera.collision_cameras`)."""
        directions: list[tuple[CarveBody, CarveBody, ContactFrame, float, NDArray[np.float64]]]
        directions = []
        counts: list[int] = []
        for target, tool, contact, target_depth, tool_depth in presses:
            before = len(directions)
            direction = np.asarray(contact.direction, dtype=np.float64)
            norm = float(np.linalg.norm(direction))
            point = np.asarray(contact.point, dtype=np.float64)
            if np.isfinite(norm) and norm > 1e-12 and np.all(np.isfinite(point)):
                direction = direction / norm
                for body, other, frame, depth in (
                    (target, tool, ContactFrame(point, direction), target_depth),
                    (tool, target, ContactFrame(point, -direction), tool_depth),
                ):
                    if np.isfinite(depth) and depth > 0.0:
                        advanced = np.array(other.model, dtype=np.float64)
                        advanced[:3, 3] += frame.direction * depth  # the tool advances
                        directions.append((body, other, frame, float(depth), advanced))
            counts.append(len(directions) - before)
        drafts = camera_drafts(
            [self._request(*direction) for direction in directions],
            self.max_resolution,
            loose=self._switches.loose_camera,
        )
        cameras = iter(collision_cameras(drafts, self._exact_lists))
        found = iter(
            [
                self._job(target, tool, depth, advanced, next(cameras))
                for target, tool, _, depth, advanced in directions
            ]
        )
        # Each press's directions, in order, less those whose bodies cannot meet.
        return [[job for job in islice(found, count) if job is not None] for count in counts]

    def _request(
        self,
        target: CarveBody,
        tool: CarveBody,
        contact: ContactFrame,
        depth: float,
        advanced: NDArray[np.float64],
    ) -> DraftRequest:
        """Pass 1 of one direction up to its triangle lists, as `camera_drafts` takes it: the
        tool at `advanced` (moved by the dent `depth` along the press)."""
        return DraftRequest(
            target.pose(),
            tool.pose(advanced),
            target.maps.size,
            contact,
            advance=depth,
            tool_list=not (self._switches.swept_quads and quad_kind(tool.gpu_mesh.mesh)),
        )

    def _job(
        self,
        target: CarveBody,
        tool: CarveBody,
        depth: float,
        advanced: NDArray[np.float64],
        camera: CollisionCamera | None,
    ) -> CarveJob | None:
        if camera is None:
            return None
        view = camera_uniforms(camera).values()
        press = Advance(u_near_clip=camera.ring_slab[0], u_advance=depth)
        return CarveJob(
            target,
            tool,
            advanced,
            camera,
            {**view, **self._pose_uniforms(target.gpu_mesh.mesh, target.model), **press.values()},
            {**view, **self._pose_uniforms(tool.gpu_mesh.mesh, advanced)},
            oblique=_oblique(target, camera, self._shared_normal(target)),
            convex=target.gpu_mesh.mesh.bound is not None,
        )

    def _shared_normal(self, body: CarveBody) -> NDArray[np.float64] | None:
        """A flat body's (a plate's) one normal in the world (`_oblique`), kept with its pose's
        uniforms for the rest of the batch; None for another body."""
        mesh = body.gpu_mesh.mesh
        if is_swept(mesh):
            return None
        found = self._posed_entry(mesh, body.model)
        if "normal" not in found[2]:
            flat = mesh.shared_normal()
            found[2]["normal"] = None if flat is None else _world_normals(flat[None, :], body.model)
        return found[2]["normal"]

    def _pose_uniforms(self, mesh: Mesh, model: NDArray[np.float64]) -> dict[str, object]:
        """`pose_uniforms` of a body posed at `model`, kept for the rest of the batch being
        planned: a burst's hits share a target and often a tool's pose."""
        return self._posed_entry(mesh, model)[1]

    def _posed_entry(
        self, mesh: Mesh, model: NDArray[np.float64]
    ) -> tuple[Mesh, dict[str, object], dict[str, NDArray[np.float64] | None]]:
        """What the batch keeps of a body posed at `model`: its mesh, pose uniforms and world
        normal (filled in by `_shared_normal`)."""
        key = (id(mesh), np.asarray(model, dtype=np.float64).tobytes())
        found = self._posed.get(key)
        if found is None or found[0] is not mesh:
            if len(self._posed) >= POSES_KEPT:
                self._posed.clear()
            found = (mesh, pose_uniforms(mesh, model), {})
            self._posed[key] = found
        return found

    # -- passes 2 and 3 ------------------------------------------------------------------------
    def _camera_stage(self, jobs: list[CarveJob], held: HeldState | None = None) -> None:
        """Pass 3, then pass 2 (it reads pass 3's front faces), of every job of a batch, each
        after one clear of the tiles' bounding box; pass 2 only for the targets that may hide
        part of themselves (not `convex`), unless `address_every_target`. Writes the batch's
        job table first: job k's target entry is k, the tools' entries follow in pass 3's
        draw order (so that the draws of one variant and map are one instanced draw). `held`:
        the state the batch's passes set so far (`gl.passes.held_state`), or None: each pass
        sets its own and leaves `neutral` state."""
        scratch = self.scratch
        indexed = list(enumerate(jobs))
        peel = self._camera_runs("peel", indexed, iter(range(len(jobs), 2 * len(jobs))))
        tools = [
            {**job.tool_uniforms, **({} if skip is None else Subset(skip).values())}
            for run in peel
            for (_, job, *_), skip in zip(run.items, run.skips, strict=True)
        ]
        self._jobs.write([_target_entry(job) for job in jobs] + tools)
        with self._timed("peel"):
            self._clear(scratch.peel_fbo, (NO_TOOL, NO_TOOL, 0.0, NO_FRONT, 1.0), jobs)
            self._camera_passes("peel", scratch.peel_fbo, peel, held)
        every = self._options.address_every_target
        hiding = [(k, job) for k, job in indexed if every or not job.convex]
        if hiding:
            with self._timed("address"):
                cleared = [job for _, job in hiding]
                self._clear(scratch.address_fbo, (NO_SURFACE, NO_SURFACE, 0.0, 0.0, 1.0), cleared)
                address = self._camera_runs("address", hiding)
                self._camera_passes("address", scratch.address_fbo, address, held)

    def _camera_runs(
        self, name: str, jobs: list[tuple[int, CarveJob]], entries: Iterator[int] | None = None
    ) -> list[_Run]:
        """Pass 2's ("address": each job's target, its entry k) or 3's ("peel": its tool,
        `entries` in draw order) draws of `jobs` (each with its place in the batch k), as runs
        drawn as one draw each. A swept solid's quads (quad.vert) and a mesh tool's triangles
        (surface.vert TILED 1) are placed in their tiles by the vertex stage, so the jobs of
        one variant that sample one map and whose entries are consecutive in one range of the
        table are one instanced draw: the quads of one variant and map; a mesh tool's lists
        where they are the same, or where their union holds at most SUBSET_TRIANGLES (each
        instance then drops the others' triangles, `Subset`). Other draws are one a job, with
        its tile as the viewport."""
        inputs = (self.scratch.tool_depth,) if name == "address" else ()
        tool = name == "peel"
        variants: dict[tuple, list[tuple]] = {}
        for k, job in jobs:
            body = job.tool if tool else job.target
            triangles = job.camera.tool_view if tool else job.camera.target_texels
            uniforms = job.tool_uniforms if tool else job.target_uniforms
            kind = uniforms.get("u_quad", 0)
            quad = kind if self._switches.swept_quads and isinstance(kind, int) else 0
            item = (k, job, None if quad else triangles, (body.maps.height, *inputs))
            variants.setdefault((name, bool(uniforms["u_swept"]), quad), []).append(item)
        runs: list[_Run] = []
        for variant, items in variants.items():
            tiled = bool(variant[2]) or (tool and bool(self._tiled))
            if tiled:  # one instanced draw per map sampled (the sort is stable)
                items.sort(key=lambda item: id(item[3][0]))
            run: _Joining | None = None
            for item in items:
                entry = item[0] if entries is None else next(entries)
                if run is None or not (tiled and run.join(entry, item)):
                    if run is not None:
                        runs.append(self._run_of(variant, run, name))
                    run = _Joining(entry, item, self._jobs.per_range)
            if run is not None:
                runs.append(self._run_of(variant, run, name))
        return runs

    def _run_of(self, variant: tuple, run: _Joining, name: str) -> _Run:
        """The draw of `run` (consecutive entries of one variant). A mesh tool of one job keeps
        its tile as the viewport: clipping its triangles at the tile's edges costs llvmpipe
        more than the viewport does (docs/carve.md, "Mesh tools instanced in pass 3")."""
        first, (_, job, triangles, _) = run.members[0]
        items = [item for _, item in run.members]
        count = len(items)
        if variant[2]:  # quads
            draw: Callable = partial(self._draw_quad, instances=count)
            return _Run(self._surface[variant], first, items, draw, [None] * count, None)
        gpu_mesh = (job.tool if name == "peel" else job.target).gpu_mesh
        if count == 1:
            draw = gpu_mesh.drawer(triangles, name)
            return _Run(self._surface[variant], first, items, draw, [None], job.viewport)
        skips: list[tuple[int, int, int, int] | None] = [None] * count
        if not run.same:
            lists = [item[2] for item in items]
            triangles = np.unique(np.concatenate(lists))
            skips = [_skip_bits(np.searchsorted(triangles, mine), len(triangles)) for mine in lists]
        draw = gpu_mesh.drawer(triangles, name, count)
        return _Run(self._tiled[variant[1]], first, items, draw, skips, None)

    def _camera_passes(
        self, name: str, fbo: moderngl.Framebuffer, runs: list[_Run], held: HeldState | None
    ) -> None:
        """Pass 2 or 3's runs (`_camera_runs`) by each job's collision camera into its tile of
        `fbo` (cleared by the batch), sampling the body's own height map (pass 2 also pass 3's
        result); the state applied once, each run one draw (instanced: gl_InstanceID is the
        entry after the first)."""
        atlas = (0, 0, *self.scratch.size)
        upload(run.draw for run in runs)  # one a stream
        with shared_batch(self.gl.ctx, fbo, _SURFACE_PASSES[name][0], held) as one:
            for run in runs:
                uniforms = {"u_job": self._jobs.use(run.first)}
                viewport = atlas if run.viewport is None else run.viewport
                one(run.pass_, viewport, run.draw, run.items[0][3], uniforms)

    def _draw_quad(self, prog: moderngl.Program, instances: int = 1) -> None:
        """quad.vert's (or util/rect.vert's) four corners (no vertex data), `instances` times."""
        if prog.glo not in self._quad_vaos:
            self._quad_vaos[prog.glo] = self.gl.ctx.vertex_array(prog, [])
        self._quad_vaos[prog.glo].render(moderngl.TRIANGLE_STRIP, vertices=4, instances=instances)

    # -- pass 5 --------------------------------------------------------------------------------
    def _normal_passes(
        self, jobs: list[tuple[int, CarveJob]], draws: list[list[tuple]], held: HeldState
    ) -> None:
        """Pass 5 of `jobs` (each with its place in the batch, sorted by the map they dent;
        `draws`: each one's `_texel_draws`) over their footprints' texels and the ring beside
        them (RING 1: the entry's `ring_slab`): the state applied once, each map's framebuffer
        bound once."""
        groups: list[list[tuple]] = []  # each map's items
        last: SurfaceMaps | None = None
        for (k, job), texel_draws in zip(jobs, draws, strict=True):
            maps = job.target.maps
            if maps is not last:
                groups.append([])
                last = maps
            for kind, draw, rect in texel_draws:
                pass_ = self._texel["normals", kind, False]
                textures = (maps.height, maps.mask)
                groups[-1].append((pass_, maps.normal_fbo, maps.size, draw, textures, k, rect))
        # The maps in the reverse of their gathers' order: the first rebuild's wait for the
        # heights it reads (a software rasteriser draws queued passes in order) is then the
        # wait for every gather, and the others wait for none.
        self._texture_space([item for group in reversed(groups) for item in group], held)

    # -- pass 4 --------------------------------------------------------------------------------
    def _gather_passes(
        self, jobs: list[tuple[int, CarveJob]], draws: list[list[tuple]], held: HeldState
    ) -> None:
        """Pass 4 of `jobs` (each with its place in the batch, sorted by the map they dent;
        `draws`: each one's `_texel_draws`): the state applied once (every variant has the
        same), each map's framebuffer bound once."""
        items: list[tuple] = []
        for (k, job), texel_draws in zip(jobs, draws, strict=True):
            maps = job.target.maps
            textures = (self.scratch.address, self.scratch.tool_depth, maps.mask)
            swept = bool(job.target_uniforms["u_swept"])
            for kind, draw, rect in texel_draws:
                pass_ = self._texel["gather", kind, swept, job.oblique, job.convex]
                items.append((pass_, maps.height_fbo, maps.size, draw, textures, k, rect))
        self._texture_space(items, held)

    def _texture_space(self, items: list[tuple], held: HeldState) -> None:
        """Passes of one state drawn over `items` (pass, framebuffer, map size, draw, textures,
        the entry of the job table, the place of its rectangle in the batch's table or None)
        in order, each over the whole of its framebuffer's map. The draws into one map's texels
        are disjoint (a chart draw keeps the texels in its chart, a gutter draw those outside),
        so their order changes no texel; the rectangles of one pass and map are drawn
        instanced, in their order (overlapping rectangles: the gathers blend MIN, the normal
        rebuilds of one texel write what the last one gives, as one draw each did), where their
        entries lie in one range of each table."""
        if not items:
            return
        pending: list[tuple] = []  # RECT items of one instanced draw
        per_range = self._jobs.per_range

        def fits(item: tuple) -> bool:
            first, last = pending[0], pending[-1]
            return (
                item[0] is first[0]
                and item[1] is first[1]
                and item[6] == last[6] + 1
                and item[6] % RECT_ENTRIES  # in the range of the rectangle before it
                and item[5] // per_range == first[5] // per_range
            )

        with shared_batch(self.gl.ctx, items[0][1], items[0][0].state, held) as one:

            def flush() -> None:
                if pending:
                    pass_, fbo, size, _, textures, entry, rect = pending[0]
                    self._jobs.use(entry)  # the range the rectangles' entries lie in
                    values = Rect(u_rect_first=self._rects.use(rect), u_viewport=size).values()
                    draw = partial(self._draw_quad, instances=len(pending))
                    one(pass_, (0, 0, *size), draw, textures, values, into=fbo)
                    pending.clear()

            for item in items:
                pass_, fbo, size, draw, textures, entry, rect = item
                if rect is None:
                    if pending and pending[0][1] is not fbo:
                        flush()
                    values = Draw(u_job=self._jobs.use(entry)).values()
                    one(pass_, (0, 0, *size), draw, textures, values, into=fbo)
                    continue
                if pending and not fits(item):
                    flush()
                pending.append(item)
            flush()
