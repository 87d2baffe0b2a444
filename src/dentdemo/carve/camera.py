"""Pass 1: the orthographic collision camera, computed on the CPU from the contact frame and both
bodies' triangles.

World space, metres. The camera looks along the press direction (the way the tool moves into the
target). Its right axis follows the target's +u tangent at the contact and its pixel pitch is the
target's texel pitch there as the camera sees it, with a pixel centre on the centre of the texel
under the contact: on a flat chart pressed square-on every pixel centre is a texel centre. Its
rectangle is the footprint bound of `footprint.overlap`, grown by two texels so that pass 5 also
reaches the texels beside the dent, and never the whole body.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from dentdemo.carve.constants import MIN_COS, RING_TEXELS, SLAB_MARGIN_TEXELS
from dentdemo.carve.footprint import Overlap, Projected, Query, Rect, meeting_many, overlap
from dentdemo.carve.linear import Floats3, column_scale, cross3, dot3, inverse3, rows_times
from dentdemo.mesh.mesh import Mesh

Vec3 = NDArray[np.float64]


@dataclass(frozen=True)
class ContactFrame:
    """Where and which way the tool presses: `point` on the target's surface at first touch (world,
    metres) and `direction`, the unit vector along which the tool moves into the target."""

    point: Vec3
    direction: Vec3


@dataclass(frozen=True, eq=False)
class CollisionCamera:
    eye: Vec3
    right: Vec3
    up: Vec3
    forward: Vec3
    #: Half width and height of the view, metres.
    half_extent: tuple[float, float]
    #: Near and far distance along `forward` from `eye`, metres.
    depth_range: tuple[float, float]
    #: Pixels (columns, rows).
    resolution: tuple[int, int]
    #: View depths (from `eye`, metres) that hold every target point the press can move.
    slab: tuple[float, float]
    #: The target's largest texel side near the contact, metres (margins of pass 5).
    texel_metres: float
    #: Triangles each pass draws (indices into the meshes): the tool's in the view (pass 3), the
    #: target's near the footprint (`texel_rect`) and in the slab grown by the ring (passes 2, 4
    #: and 5).
    tool_view: NDArray[np.int64]
    target_texels: NDArray[np.int64]
    #: Those of `target_texels` on a chart border (the gutter draws of passes 4 and 5); none
    #: where the target's charts fill its map (`Mesh.charts_fill_map`: it has no gutter).
    target_gutter: NDArray[np.int64]
    #: What is worked out from the lists when first needed (undo.footprint_boxes).
    derived: dict[str, object] = field(default_factory=dict, compare=False, repr=False)

    @property
    def pixel_metres(self) -> tuple[float, float]:
        return (
            2.0 * self.half_extent[0] / self.resolution[0],
            2.0 * self.half_extent[1] / self.resolution[1],
        )

    @property
    def ring_slab(self) -> tuple[float, float]:
        """The slab of pass 5 (view depth, metres): pass 4's and the texels beside it."""
        grow = RING_TEXELS * self.texel_metres
        return self.slab[0] - grow, self.slab[1] + grow

    @property
    def pixels(self) -> int:
        return self.resolution[0] * self.resolution[1]


@dataclass(frozen=True)
class BodyPose:
    """What pass 1 needs of one body: its mesh, pose (world from local) and the range its height
    map can hold (metres: no height above `max_height`, none below -`max_dent_depth`)."""

    mesh: Mesh
    model: NDArray[np.float64]
    max_height: float = 0.0
    max_dent_depth: float = 0.0
    #: The finer side of the body's texels, metres (0: unknown).
    texel_metres: float = 0.0


# The few vectors of a camera's frame are worked out on Python floats (carve/linear.py), which
# cost less per operation than numpy calls on arrays of three.
def _floats(v: object) -> Floats3:
    x, y, z = np.asarray(v, dtype=np.float64).tolist()
    return x, y, z


def _length(v: Floats3) -> float:
    return math.sqrt(dot3(v, v))


def _scaled(v: Floats3, k: float) -> Floats3:
    return v[0] * k, v[1] * k, v[2] * k


def _unit(v: Floats3) -> Floats3:
    return _scaled(v, 1.0 / max(_length(v), 1e-30))


def _across(v: Floats3, unit: Floats3) -> Floats3:
    """`v` less its part along `unit`."""
    along = dot3(v, unit)
    return v[0] - along * unit[0], v[1] - along * unit[1], v[2] - along * unit[2]


def _axes(dpdu: Floats3, forward: Floats3) -> tuple[Floats3, Floats3]:
    right = _across(dpdu, forward)
    if _length(right) < 1e-9 * max(_length(dpdu), 1e-30):
        right = _across((1.0, 0.0, 0.0) if abs(forward[0]) < 0.9 else (0.0, 0.0, 1.0), forward)
    right = _unit(right)
    return right, cross3(right, forward)


@dataclass(frozen=True)
class CameraDraft:
    """A collision camera but for its triangle lists, which `collision_cameras` finds for a
    batch's cameras together: the posed meshes, the view rectangle, and the s ranges of the
    target's triangles and, where pass 3 draws a list of the tool's, of the tool's."""

    target: BodyPose
    target_tris: Projected
    tool_tris: Projected
    view: Rect
    #: The rectangle the target's triangle lists must meet (`texel_rect`).
    texel_view: Rect
    texel_slab: tuple[float, float]
    tool_slab: tuple[float, float] | None
    #: Every field of the camera but `tool_view`, `target_texels` and `target_gutter`.
    fields: dict[str, object]


def camera_draft(
    target: BodyPose,
    tool: BodyPose,
    map_size: tuple[int, int],
    contact: ContactFrame,
    max_resolution: int,
    loose: bool = False,
    advance: float = 0.0,
    tool_list: bool = True,
) -> CameraDraft | None:
    """The camera for carving `target` by `tool` (already advanced by the dent depth) at
    `contact`, up to its triangle lists (`collision_cameras` finds those of a batch's drafts
    together); None when the bodies cannot overlap.

    `loose` bounds the view by both bodies' bounding spheres instead of the footprint (for tests
    of the footprint bound only). `advance`: how far the tool was moved along the press from
    first touch, metres. `tool_list` False: pass 3 draws the tool without a triangle list (a
    sphere as one quad).
    """
    model = np.asarray(target.model, dtype=np.float64)
    linear = model[:3, :3]
    rows = linear.tolist()
    forward = _unit(_floats(contact.direction))
    point = _floats(contact.point)
    tx, ty, tz = model[:3, 3].tolist()
    rel = (point[0] - tx, point[1] - ty, point[2] - tz)
    surf = target.mesh.frame_near(np.array(rows_times(inverse3(linear).tolist(), rel)))
    # World metres per uv unit.
    dpdu = rows_times(rows, _floats(surf.dpdu))
    dpdv = rows_times(rows, _floats(surf.dpdv))
    width, height = map_size
    right, up = _axes(dpdu, forward)

    # Texel pitch as the camera sees it, metres; grazing views are clamped.
    texel_u = _length(dpdu) / width
    texel_v = _length(dpdv) / height
    pitch_x = max(abs(dot3(dpdu, right)) / width, MIN_COS * texel_u)
    pitch_y = max(abs(dot3(dpdv, up)) / height, MIN_COS * texel_v)
    # The tool is known to its own texels only: where the target's texels are finer, a pixel spans
    # a whole number of them (pixel centres stay on texel centres) up to one of the tool's texels.
    pitch_x *= max(1, math.floor(tool.texel_metres / pitch_x))
    pitch_y *= max(1, math.floor(tool.texel_metres / pitch_y))

    # A pixel centre on the centre of the texel under the contact.
    u, v = surf.uv.tolist()
    du = (math.floor(u * width) + 0.5) / width - u
    dv = (math.floor(v * height) + 0.5) / height - v
    origin = tuple(p + a * du + b * dv for p, a, b in zip(point, dpdu, dpdv, strict=True))

    axes, at = np.array([right, up, forward]), np.array(origin)
    target_tris = Projected(target.mesh, model, at, axes)
    tool_tris = Projected(tool.mesh, tool.model, at, axes)
    bound = overlap(target_tris, tool_tris, target.max_height, tool.max_height, advance)
    if bound is None:
        return None
    if loose:
        bound = _loose(target_tris, tool_tris, bound)
    margin = 2.0 * max(texel_u, texel_v) + max(pitch_x, pitch_y)
    rect = bound.rect.grown(margin)

    # Pixel centres at whole multiples of the pitch from the origin.
    def lattice(lo: float, hi: float, pitch: float) -> tuple[float, int, float]:
        k0, k1 = math.floor(lo / pitch), math.ceil(hi / pitch)
        count = k1 - k0 + 1
        if count > max_resolution:  # capped: fewer, larger pixels over the same span
            count = max_resolution
            pitch = (hi - lo) / (count - 1)
            return (lo + hi) / 2, count, pitch
        return (k0 + k1) / 2 * pitch, count, pitch

    cx, cols, pitch_x = lattice(rect.x0, rect.x1, pitch_x)
    cy, rows, pitch_y = lattice(rect.y0, rect.y1, pitch_y)

    # Depth range: everything of both bodies, so that nothing in front of the target is clipped.
    bumps = sum(max(b.max_height, 0.0) + max(b.max_dent_depth, 0.0) for b in (target, tool))
    near_s = min(target_tris.s_range()[0], tool_tris.s_range()[0]) - bumps - 1e-4
    far_s = max(target_tris.s_range()[1], tool_tris.s_range()[1]) + bumps + 1e-4
    eye = np.array(
        [
            o + r * cx + w * cy + f * near_s
            for o, r, w, f in zip(origin, right, up, forward, strict=True)
        ]
    )
    texel = max(texel_u, texel_v)
    half_x, half_y = cols * pitch_x / 2.0, rows * pitch_y / 2.0
    view = Rect(cx - half_x, cx + half_x, cy - half_y, cy + half_y)
    # A built-in sphere or capsule is dented at its texels' points on the smooth solid but
    # clipped at their facet points, which lie up to its facet sag deeper (mesh.facet_sag).
    sag = target.mesh.facet_sag() * column_scale(linear)
    gather = (
        bound.slab[0] - SLAB_MARGIN_TEXELS * texel,
        bound.slab[1] + SLAB_MARGIN_TEXELS * texel + sag,
    )
    ring = RING_TEXELS * texel
    proud = max(target.max_height, 0.0) + max(tool.max_height, 0.0)
    # Pass 2 sees the target from the slab's near side on (a nearer surface lies behind the tool:
    # it neither hides the slab nor takes a dent), up to its far side. Pass 3 draws the tool's
    # faces that reach past the slab's near side (two pixels more for the bilinear neighbours at
    # the rim): a front face nearer than that is nearer than every target surface pass 2 keeps,
    # so leaving it out drops nothing that pass 2 or 4 would test against it.
    return CameraDraft(
        target=target,
        target_tris=target_tris,
        tool_tris=tool_tris,
        view=view,
        texel_view=texel_rect(target, bound.rect, 2.0 * texel, view),
        texel_slab=(gather[0] - ring, gather[1] + ring),
        tool_slab=(gather[0] - proud - 2.0 * max(pitch_x, pitch_y), np.inf) if tool_list else None,
        fields={
            "eye": eye,
            "right": axes[0],
            "up": axes[1],
            "forward": axes[2],
            "half_extent": (half_x, half_y),
            "depth_range": (0.0, far_s - near_s),
            "resolution": (int(cols), int(rows)),
            "slab": (gather[0] - near_s, gather[1] - near_s),
            "texel_metres": texel,
        },
    )


def texel_rect(target: BodyPose, bound: Rect, margin: float, view: Rect) -> Rect:
    """The rectangle (camera x, y, metres) whose triangles of `target` passes 4 and 5 draw:
    the footprint `bound` grown by `margin` (two of the target's texels, twice the reach of
    pass 5's differences), within `view`. The view's own margin is a pixel more, and its pixels
    span up to one of the tool's texels (a body that takes no dents has coarse ones: the
    ground's are 0.25 m), but a texel farther than `margin` from the footprint neither changes
    nor neighbours one that does. A target that may hide part of itself keeps the whole view:
    pass 2 draws the same list, and a pixel's nearest surface may lie up to half a pixel
    outside the footprint's."""
    if target.mesh.bound is None:
        return view
    return bound.grown(margin).intersect(view) or view


def collision_cameras(
    drafts: Sequence[CameraDraft | None], exact_lists: bool = True
) -> list[CollisionCamera | None]:
    """The cameras of `drafts` (None stays None), their triangle lists found together
    (`footprint.meeting_many`: the cluster tests of a batch's hits in one set of array
    operations); None also where an open body has no face that can take part. `exact_lists`
    False makes the lists whole clusters (less CPU, more triangles for the GPU to clip)."""
    queries: list[Query] = []
    for draft in drafts:
        if draft is not None:
            queries.append((draft.target_tris, draft.texel_view, draft.texel_slab))
            if draft.tool_slab is not None:
                queries.append((draft.tool_tris, draft.view, draft.tool_slab))
    lists = iter(meeting_many(queries, exact_lists))
    cameras: list[CollisionCamera | None] = []
    for draft in drafts:
        if draft is None:
            cameras.append(None)
            continue
        texels = next(lists)
        tool_view = next(lists) if draft.tool_slab is not None else np.zeros(0, dtype=np.int64)
        # An open body (a plate) has material on one side only: an open tool pushes only with
        # faces turned away from the view, an open target takes dents only in faces turned
        # towards it.
        tool_tris, target_tris = draft.tool_tris, draft.target_tris
        if (not tool_tris.solid and not tool_tris.faces_away(tool_view)) or (
            not target_tris.solid and not target_tris.faces_away(texels, away=False)
        ):
            cameras.append(None)
            continue
        mesh = draft.target.mesh
        # A map whose charts fill it has no gutter texel to draw (Mesh.charts_fill_map).
        gutter = texels[:0] if mesh.charts_fill_map() else texels[mesh.chart_border()[texels]]
        cameras.append(
            CollisionCamera(
                **draft.fields,  # type: ignore[arg-type]
                tool_view=tool_view,
                target_texels=texels,
                target_gutter=gutter,
            )
        )
    return cameras


def _loose(target: Projected, tool: Projected, bound: Overlap) -> Overlap:
    """Both bodies' whole extents: the bound before the footprint (tests only)."""
    rect = target.rect().intersect(tool.rect()) or bound.rect
    return Overlap(rect, target.s_range())
