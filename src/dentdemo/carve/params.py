"""The carve's shader parameters, typed: each family of passes (passes 2 and 3 seen by the
collision camera, passes 4 and 5 drawn in texture space) has a frozen dataclass of its values,
made of small groups (one per include or stage that reads them), and its variants are picked
by enums. The groups of `ENTRY_GROUPS` are a job's entry in the batch's job table (one uniform
buffer, carve/jobs.py, shaders/carve/job.glsl); the others are plain uniforms of a draw.
`check_program` holds each program, when it is built, to its family: every plain uniform the
program keeps must be a field of it (the others a compiler dropped from a variant are skipped
when set), every field must be a uniform some shader declares or a member of the job table's
entry, and the table's layout must be the driver's."""

from __future__ import annotations

from dataclasses import dataclass, fields
from enum import IntEnum
from typing import ClassVar

import moderngl

from dentdemo.carve.jobs import BLOCK, check_layout, entry_layout
from dentdemo.errors import ShaderError
from dentdemo.gl.shaders import library_uniforms

Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]
IVec2 = tuple[int, int]


class Quad(IntEnum):
    """How passes 2 and 3 draw a body (their QUAD variant): its triangles, or a built-in sphere
    or capsule as one quad over its extent (carve/quad.vert)."""

    NONE = 0
    SPHERE = 1
    CAPSULE = 2


class TexelDraw(IntEnum):
    """How a texture-space draw of passes 4 and 5 covers its texels: the chart texels of the
    footprint's triangles, the gutter texels around their chart borders (texel.geom, GUTTER 1),
    or a built-in sphere's chart texels in rectangles (util/rect.vert, RECT 1)."""

    CHART = 0
    GUTTER = 1
    RECT = 2


class _Group:
    """A few uniforms declared together; fields left None are not set by this draw (only a
    group with `OPTIONAL` fields has any)."""

    OPTIONAL: ClassVar[bool] = False

    def values(self) -> dict[str, object]:
        """The uniforms by name (to be read, not changed: a group without optional fields
        gives its own field dict)."""
        if not self.OPTIONAL:
            return vars(self)
        return {name: value for name, value in vars(self).items() if value is not None}


@dataclass(frozen=True)
class Camera(_Group):
    """camera.glsl: the orthographic collision camera (world metres) and its tile."""

    u_eye: Vec3
    u_right: Vec3
    u_up: Vec3
    u_forward: Vec3
    #: Half width and height of the view, metres.
    u_half_extent: Vec2
    #: Near and far view depth, metres.
    u_depth_range: Vec2
    #: Pixels (columns, rows).
    u_resolution: IVec2
    #: The camera's pixel (0, 0) in the scratch atlas.
    u_tile: IVec2 = (0, 0)


@dataclass(frozen=True)
class Pose(_Group):
    """surface.vert, texel.vert: world from local (column-major float32 mat4) and the normal
    matrix (the inverse of its linear part, transposed: column-major mat3)."""

    u_model: bytes
    u_normal_matrix: bytes


@dataclass(frozen=True)
class Swept(_Group):
    """swept.glsl (a built-in sphere or capsule's own solid, world metres), cube_grid.glsl (a
    sphere's cells: RECT draws), capsule_uv.glsl (a capsule's atlas)."""

    OPTIONAL: ClassVar[bool] = True

    u_swept_a: Vec3
    u_swept_b: Vec3
    u_swept_radius: float
    #: Local from world, column-major float32 mat3.
    u_swept_local: bytes
    u_cube_grid: int | None = None
    u_cube_radius: float | None = None
    #: Local radius, half the straight length, rows per hemisphere.
    u_capsule: Vec3 | None = None


@dataclass(frozen=True)
class Advance(_Group):
    """The target's press: surface.vert's clip of pass 2 (view depth, metres) and how far the
    tool was advanced along the press (gather.frag, metres)."""

    u_near_clip: float
    u_advance: float


@dataclass(frozen=True)
class Clip(_Group):
    """clip.glsl: the texels kept (all, or those in the camera's rectangle and a slab)."""

    OPTIONAL: ClassVar[bool] = True

    u_clip: bool
    u_map_size: IVec2
    #: Half width and height of the kept rectangle, camera metres.
    u_clip_half: Vec2 | None = None
    #: Kept view depths (near, far), metres: pass 4's slab, and pass 5's grown by its ring.
    u_slab: Vec2 | None = None
    u_ring_slab: Vec2 | None = None


@dataclass(frozen=True)
class Gather(_Group):
    """gather.frag: the target's height bounds and the camera's pixel, metres."""

    u_min_height: float
    u_ceiling: float
    u_pixel_diagonal: float


@dataclass(frozen=True)
class Rect(_Group):
    """util/rect.vert with RECT_TABLE 1: the first of an instanced draw's rectangles of texels in
    the batch's table (carve/jobs.py, `RectTable`), in a map of `u_viewport` texels."""

    u_rect_first: int
    u_viewport: IVec2


@dataclass(frozen=True)
class Draw(_Group):
    """job.glsl: the draw's entry in the job table's range bound."""

    u_job: int


@dataclass(frozen=True)
class Subset(_Group):
    """peel.geom (TILED 1): the triangles of an instanced draw's list (the union of its jobs'
    lists, at most `constants.SUBSET_TRIANGLES`) that are not this job's: bit i of the four
    ints (32 each) set where triangle i is another's; none set: every triangle is its own."""

    u_list_skip: tuple[int, int, int, int]


#: The groups a job's entry in the batch's job table holds (carve/jobs.py): what every draw of
#: a job (or of its body) shares. `Draw` and `Rect` stay plain uniforms, one or two a draw.
ENTRY_GROUPS: tuple[type, ...] = (Camera, Pose, Swept, Advance, Clip, Gather, Subset)


class _Family:
    """A family's uniforms: its groups' fields."""

    GROUPS: ClassVar[tuple[type, ...]]

    def values(self) -> dict[str, object]:
        """Every uniform this draw sets, by name."""
        out: dict[str, object] = {}
        for group in vars(self).values():
            if group is not None:
                out.update(group.values())
        return out


@dataclass(frozen=True)
class SurfaceUniforms(_Family):
    """Passes 2 and 3 (surface.vert or quad.vert; address.frag, peel.frag)."""

    GROUPS: ClassVar[tuple[type, ...]] = (Camera, Pose, Swept, Advance, Subset, Draw)
    camera: Camera
    pose: Pose
    swept: Swept | None = None
    advance: Advance | None = None
    subset: Subset | None = None


@dataclass(frozen=True)
class TexelUniforms(_Family):
    """Passes 4 and 5 (texel.vert, texel.geom or util/rect.vert; gather.frag, normals.frag)."""

    GROUPS: ClassVar[tuple[type, ...]] = (
        Camera,
        Pose,
        Swept,
        Advance,
        Clip,
        Gather,
        Rect,
        Draw,
    )
    pose: Pose
    clip: Clip
    camera: Camera | None = None
    swept: Swept | None = None
    advance: Advance | None = None
    gather: Gather | None = None
    rect: Rect | None = None


def family_names(family: type[_Family]) -> frozenset[str]:
    """The uniform names of a family's groups; each must be one some shader file declares or a
    member of the job table's entry."""
    names = frozenset(f.name for group in family.GROUPS for f in fields(group))
    undeclared = names - library_uniforms() - entry_layout().names()
    if undeclared:
        raise ShaderError(f"{family.__name__}: no shader declares {sorted(undeclared)}")
    return names


def check_program(
    prog: moderngl.Program, family: type[_Family], samplers: tuple[str, ...], where: str
) -> None:
    """Hold a program just built to its family: each plain uniform it keeps is one of the
    family's fields or one of the textures it samples (`samplers`), and a job table it reads is
    laid out as carve/jobs.py packs it (`check_layout`), else ShaderError naming `where`."""
    kept = {name for name in prog if isinstance(prog[name], moderngl.Uniform)}
    stray = kept - family_names(family) - set(samplers)
    if stray:
        raise ShaderError(f"{where}: uniforms {sorted(stray)} are not fields of {family.__name__}")
    if isinstance(prog.get(BLOCK, None), moderngl.UniformBlock):
        check_entry()
        check_layout(prog, where)


def check_entry() -> None:
    """Hold the job table's entry (shaders/carve/job.glsl) to `ENTRY_GROUPS`: every member is a
    field of one of the groups and every field a member, else ShaderError."""
    names = entry_layout().names()
    groups = {f.name for group in ENTRY_GROUPS for f in fields(group)}
    if names != groups:
        raise ShaderError(
            f"carve/job.glsl: CarveEntry lacks {sorted(groups - names)} and has"
            f" {sorted(names - groups)} beyond the parameter groups"
        )
