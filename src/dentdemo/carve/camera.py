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

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dentdemo.carve import lanes
from dentdemo.carve.constants import MIN_COS, RING_TEXELS, SLAB_MARGIN_TEXELS
from dentdemo.carve.footprint import Overlap, Projected, Query, Rect, lists_many, overlap
from dentdemo.carve.linear import column_scale, cross3, dot3, inverse_rows, rows_times
from dentdemo.carve.solids import (
    ARRAY_BOUNDS,
    Poses,
    Solids,
    overlap_solids,
    pose_lanes,
    solid_kind,
)
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


class DraftRequest(NamedTuple):
    """One direction of a hit for `camera_drafts`: `target` carved by `tool` (already advanced
    by the dent depth, `advance` metres along the press from first touch) at `contact`;
    `tool_list` False: pass 3 draws the tool without a triangle list (a sphere as one quad)."""

    target: BodyPose
    tool: BodyPose
    map_size: tuple[int, int]
    contact: ContactFrame
    advance: float = 0.0
    tool_list: bool = True


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
    together); None when the bodies cannot overlap. `camera_drafts` of one request.

    `loose` bounds the view by both bodies' bounding spheres instead of the footprint (for tests
    of the footprint bound only).
    """
    request = DraftRequest(target, tool, map_size, contact, advance, tool_list)
    return camera_drafts([request], max_resolution, loose)[0]


def camera_drafts(
    requests: Sequence[DraftRequest], max_resolution: int, loose: bool = False
) -> list[CameraDraft | None]:
    """`camera_draft` of each request: their camera frames (`_frames`), then each one's
    footprint bound (`footprint.overlap`), then the lattices, depth ranges and slabs of those
    whose bodies can meet (`_views`). From ARRAY_DIRECTIONS directions on, each step of the
    frames and views is one array expression over all of them; fewer are worked out one by
    one on Python floats, by the same expressions (`lanes.Lane`)."""
    if len(requests) >= ARRAY_DIRECTIONS:
        return _drafts(requests, max_resolution, loose, lanes.ARRAY)
    return [
        draft
        for request in requests
        for draft in _drafts([request], max_resolution, loose, lanes.ONE)
    ]


#: Directions from which a batch's frames and views are worked out as arrays: numpy's price
#: per call, paid once a step, then costs less than Python's per float, paid once a direction
#: (docs/performance.md).
ARRAY_DIRECTIONS = 7


class _Frames(NamedTuple):
    """The camera frames of a batch's directions (world metres): each one's axes (3 x 3:
    right, up, forward as rows) and origin (the centre of the target texel under its
    contact), and as lanes the target's texel sides along u and v and the pixel pitches along
    x and y (before the lattice)."""

    axes: list[NDArray[np.float64]]
    origin: list[NDArray[np.float64]]
    texel: tuple[lanes.Lane, lanes.Lane]
    pitch: tuple[lanes.Lane, lanes.Lane]
    #: `axes` and `origin` as arrays over the directions, (n, 3, 3) and (n, 3).
    axes_array: NDArray[np.float64]
    origin_array: NDArray[np.float64]
    #: `axes` and `origin` as lanes: the rows (right, up, forward) and the origin.
    rows: tuple[lanes.Lanes3, lanes.Lanes3, lanes.Lanes3]
    origin_lanes: lanes.Lanes3
    #: The targets' poses: each row's lanes (linear part's row, translation).
    target_model: list[tuple[lanes.Lane, ...]]


def _drafts(
    requests: Sequence[DraftRequest],
    max_resolution: int,
    loose: bool,
    mode: lanes.Mode,
) -> list[CameraDraft | None]:
    """`camera_drafts` of `requests`, their frames and views worked out in lanes made by
    `mode`, the footprint bounds of built-in solids over arrays (`solids`) and of other meshes
    one by one (`footprint.overlap`)."""
    frames = _frames(requests, mode)
    tool_models = [np.asarray(r.tool.model, dtype=np.float64)[:3].tolist() for r in requests]
    models = (frames.target_model, [mode.columns([m[i] for m in tool_models]) for i in range(3)])
    poses = [pose_lanes(mode, frames.rows, frames.origin_lanes, model) for model in models]
    arrays = [p.arrays(mode) for p in poses]
    tris = [
        [Projected.of(getattr(r, body).mesh, pose, k) for k, r in enumerate(requests)]
        for body, pose in zip(("target", "tool"), arrays, strict=True)
    ]
    bounds = _bounds(requests, arrays, tris, loose)
    drafts: list[CameraDraft | None] = [None] * len(requests)
    at = [k for k, bound in enumerate(bounds) if bound is not None]
    if at:
        views = _views(requests, frames, at, bounds, tris, max_resolution, mode)
        for k, draft in zip(at, views, strict=True):
            drafts[k] = draft
    return drafts


#: A direction's footprint bound (camera metres): its rectangle (x0, x1, y0, y1), slab (lo,
#: hi) and both bodies' whole s extents (target lo, hi, tool lo, hi: the depth range).
_Bound = tuple[float, ...]


def _bounds(
    requests: Sequence[DraftRequest],
    poses: list[Poses],
    tris: list[list[Projected]],
    loose: bool,
) -> list[_Bound | None]:
    """The footprint bound of each direction (None where its bodies cannot meet): those whose
    bodies are both built-in solids of one pair of kinds, from `solids.ARRAY_BOUNDS` of them
    on, together (`solids.overlap_solids`, arrays over the directions), the others one by one
    (`footprint.overlap`, Python floats: the same bits), and with `loose` all of them by the
    whole bodies."""
    found: list[_Bound | None] = [None] * len(requests)
    groups: dict[tuple, list[int]] = {}
    alone: list[int] = []
    for k, r in enumerate(requests):
        kinds = (solid_kind(r.target.mesh), solid_kind(r.tool.mesh))
        if loose or kinds[0] is None or kinds[1] is None:
            alone.append(k)
        else:
            groups.setdefault(kinds, []).append(k)
    for (target_kind, tool_kind), members in groups.items():
        if len(members) < ARRAY_BOUNDS:
            alone += members
            continue
        at = np.array(members)
        chosen = [requests[k] for k in members]
        bounds = overlap_solids(
            Solids([r.target.mesh.bound for r in chosen], poses[0].take(at), target_kind[-1]),  # type: ignore[misc]
            Solids([r.tool.mesh.bound for r in chosen], poses[1].take(at), tool_kind[-1]),  # type: ignore[misc]
            *np.array([(r.target.max_height, r.tool.max_height, r.advance) for r in chosen]).T,
        )
        rows = np.array([*bounds.rect, *bounds.slab, *bounds.target_s, *bounds.tool_s]).T
        for k, meets, row in zip(members, bounds.meets.tolist(), rows.tolist(), strict=True):
            found[k] = tuple(row) if meets else None
    for k in alone:
        target, tool = requests[k].target, requests[k].tool
        target_tris, tool_tris = tris[0][k], tris[1][k]
        bound = overlap(
            target_tris, tool_tris, target.max_height, tool.max_height, requests[k].advance
        )
        if bound is not None:
            if loose:
                bound = _loose(target_tris, tool_tris, bound)
            rect = bound.rect
            found[k] = (
                rect.x0,
                rect.x1,
                rect.y0,
                rect.y1,
                *bound.slab,
                *target_tris.s_range(),
                *tool_tris.s_range(),
            )
    return found


def _frames(requests: Sequence[DraftRequest], mode: lanes.Mode) -> _Frames:
    """The camera frame of every request, each step one expression over the lanes (`lanes.Lane`).
    The view looks along the press; `right` follows the target's +u tangent at the contact,
    its pitch the target's texel as the camera sees it, a pixel spanning a whole number of
    target texels up to one of the tool's, and the origin is the centre of the target texel
    under the contact."""

    models = [np.asarray(r.target.model, dtype=np.float64)[:3].tolist() for r in requests]
    # Row i of the pose: (linear part's row i, translation i).
    rows = [mode.columns([m[i] for m in models]) for i in range(3)]
    linear = [row[:3] for row in rows]
    forward = mode.unit(
        mode.columns([np.asarray(r.contact.direction, dtype=np.float64).tolist() for r in requests])
    )
    point = mode.columns([np.asarray(r.contact.point, dtype=np.float64).tolist() for r in requests])
    rel = tuple(p - row[3] for p, row in zip(point, rows, strict=True))
    local = np.array(mode.rows(rows_times(inverse_rows(linear), rel)), dtype=np.float64)
    # Each target's triangle near the contact (a mesh's own look-up), its uv extended to it.
    surfs = [r.target.mesh.frame_near(p) for r, p in zip(requests, local, strict=True)]
    u, v = mode.columns([s.uv.tolist() for s in surfs])
    # World metres per uv unit.
    dpdu = rows_times(linear, mode.columns([s.dpdu.tolist() for s in surfs]))
    dpdv = rows_times(linear, mode.columns([s.dpdv.tolist() for s in surfs]))
    width, height = mode.columns([[float(x) for x in r.map_size] for r in requests])
    # Right along dP/du across the view, or a fixed axis across it where dP/du is along it.
    right = lanes.across(dpdu, forward)
    length_u = mode.sqrt(dot3(dpdu, dpdu))
    along = mode.sqrt(dot3(right, right)) < 1e-9 * mode.greater(length_u, 1e-30)
    if mode.any_of(along):
        x_ok = abs(forward[0]) < 0.9
        fixed = (mode.where(x_ok, 1.0, 0.0), 0.0, mode.where(x_ok, 0.0, 1.0))
        across = lanes.across(fixed, forward)
        right = tuple(mode.where(along, a, r) for a, r in zip(across, right, strict=True))
    right = mode.unit(right)
    up = cross3(right, forward)
    # Texel pitch as the camera sees it, metres; grazing views are clamped.
    texel_u = length_u / width
    texel_v = mode.sqrt(dot3(dpdv, dpdv)) / height
    pitch_x = mode.greater(abs(dot3(dpdu, right)) / width, MIN_COS * texel_u)
    pitch_y = mode.greater(abs(dot3(dpdv, up)) / height, MIN_COS * texel_v)
    # The tool is known to its own texels only: where the target's texels are finer, a pixel
    # spans a whole number of them (pixel centres stay on texel centres) up to one of the
    # tool's texels.
    (tool_texel,) = mode.columns([[r.tool.texel_metres] for r in requests])
    pitch_x = pitch_x * mode.greater(1.0, mode.floor(tool_texel / pitch_x))
    pitch_y = pitch_y * mode.greater(1.0, mode.floor(tool_texel / pitch_y))
    # A pixel centre on the centre of the texel under the contact.
    du = (mode.floor(u * width) + 0.5) / width - u
    dv = (mode.floor(v * height) + 0.5) / height - v
    origin = tuple(p + a * du + b * dv for p, a, b in zip(point, dpdu, dpdv, strict=True))
    if mode is lanes.ONE:
        axes_array, origin_array = np.array([[right, up, forward]]), np.array([origin])
    else:
        axes_array = np.ascontiguousarray(np.array([right, up, forward]).transpose(2, 0, 1))
        origin_array = np.array(origin).T.copy()
    return _Frames(
        list(axes_array),
        list(origin_array),
        (texel_u, texel_v),
        (pitch_x, pitch_y),
        axes_array,
        origin_array,
        (right, up, forward),
        origin,
        rows,
    )


def _views(
    requests: Sequence[DraftRequest],
    frames: _Frames,
    at: list[int],
    bounds: list[_Bound | None],
    tris: list[list[Projected]],
    max_resolution: int,
    mode: lanes.Mode,
) -> list[CameraDraft]:
    """The drafts of the directions `at` of `requests` (whose bodies can meet, by `bounds`):
    each one's lattice of pixels over its bound, depth range, slabs and the rectangle of its
    target's triangle lists, one expression per step over the lanes (`lanes.Lane`)."""

    # The frames' lanes, of the directions posed.
    texel_u, texel_v, pitch_x, pitch_y = (
        x[at] if isinstance(x, np.ndarray) else x for x in (*frames.texel, *frames.pitch)
    )
    (x0, x1, y0, y1, slab_lo, slab_hi, target_lo, target_hi, tool_lo, tool_hi) = mode.columns(
        [bounds[k] for k in at]  # type: ignore[misc]
    )
    texel = mode.greater(texel_u, texel_v)
    margin = 2.0 * texel + mode.greater(pitch_x, pitch_y)

    # Pixel centres at whole multiples of the pitch from the origin; beyond `max_resolution`
    # pixels a side, fewer larger ones over the same span.
    def lattice(
        lo: lanes.Lane, hi: lanes.Lane, pitch: lanes.Lane
    ) -> tuple[lanes.Lane, lanes.Lane, lanes.Lane]:
        k0, k1 = mode.floor(lo / pitch), mode.ceil(hi / pitch)
        count = k1 - k0 + 1
        capped = count > max_resolution
        return (
            mode.where(capped, (lo + hi) / 2, (k0 + k1) / 2 * pitch),
            mode.where(capped, float(max_resolution), count),
            mode.where(capped, (hi - lo) / (max_resolution - 1), pitch),
        )

    cx, cols, pitch_x = lattice(x0 - margin, x1 + margin, pitch_x)
    cy, rows, pitch_y = lattice(y0 - margin, y1 + margin, pitch_y)
    # Depth range: everything of both bodies, so that nothing in front of the target is
    # clipped.
    bodies = [requests[k] for k in at]
    target_height, target_dent, tool_height, tool_dent = (
        mode.greater(x, 0.0)
        for x in mode.columns(
            [
                (
                    r.target.max_height,
                    r.target.max_dent_depth,
                    r.tool.max_height,
                    r.tool.max_dent_depth,
                )
                for r in bodies
            ]
        )
    )
    bumps = 0 + (target_height + target_dent) + (tool_height + tool_dent)
    near_s = mode.lesser(target_lo, tool_lo) - bumps - 1e-4
    far_s = mode.greater(target_hi, tool_hi) + bumps + 1e-4
    if mode is lanes.ONE:
        right, up, forward = frames.rows
        origin = frames.origin_lanes
    else:
        right, up, forward = (tuple(x[at] for x in row) for row in frames.rows)
        origin = tuple(x[at] for x in frames.origin_lanes)
    eye = tuple(
        o + r * cx + w * cy + f * near_s
        for o, r, w, f in zip(origin, right, up, forward, strict=True)
    )
    half_x, half_y = cols * pitch_x / 2.0, rows * pitch_y / 2.0
    # A built-in sphere or capsule is dented at its texels' points on the smooth solid but
    # clipped at their facet points, which lie up to its facet sag deeper (mesh.facet_sag).
    sag = mode.lane(
        [
            r.target.mesh.facet_sag() * column_scale(np.asarray(r.target.model)[:3, :3])
            for r in bodies
        ]
    )
    gather_lo = slab_lo - SLAB_MARGIN_TEXELS * texel
    gather_hi = slab_hi + SLAB_MARGIN_TEXELS * texel + sag
    ring = RING_TEXELS * texel
    proud = target_height + tool_height
    # Pass 2 sees the target from the slab's near side on (a nearer surface lies behind the
    # tool: it neither hides the slab nor takes a dent), up to its far side. Pass 3 draws the
    # tool's faces that reach past the slab's near side (two pixels more for the bilinear
    # neighbours at the rim): a front face nearer than that is nearer than every target
    # surface pass 2 keeps, so leaving it out drops nothing that pass 2 or 4 would test
    # against it.
    tool_near = gather_lo - proud - 2.0 * mode.greater(pitch_x, pitch_y)
    vx0, vx1, vy0, vy1 = cx - half_x, cx + half_x, cy - half_y, cy + half_y
    # Passes 4 and 5 draw the target's triangles in the bound grown by two texels, within the
    # view (`texel_rect`), or the whole view for a target that may hide part of itself.
    grow = 2.0 * texel
    tx0, tx1 = mode.greater(x0 - grow, vx0), mode.lesser(x1 + grow, vx1)
    ty0, ty1 = mode.greater(y0 - grow, vy0), mode.lesser(y1 + grow, vy1)
    (solid,) = mode.columns([[float(r.target.mesh.bound is not None)] for r in bodies])
    inside = (tx0 <= tx1) & (ty0 <= ty1) & (solid > 0.0)
    outputs = (
        vx0,
        vx1,
        vy0,
        vy1,
        half_x,
        half_y,
        cols,
        rows,
        texel,
        gather_lo - ring,
        gather_hi + ring,
        tool_near,
        far_s - near_s,
        gather_lo - near_s,
        gather_hi - near_s,
        *eye,
        mode.where(inside, tx0, vx0),
        mode.where(inside, tx1, vx1),
        mode.where(inside, ty0, vy0),
        mode.where(inside, ty1, vy1),
    )
    columns = mode.rows(outputs)
    drafts = []
    for k, values in zip(at, columns, strict=True):
        (vx0, vx1, vy0, vy1, hx, hy, nx, ny, texel_k, lo, hi, tool_s, depth, near, far) = values[
            :15
        ]
        request, frame = requests[k], frames.axes[k]
        drafts.append(
            CameraDraft(
                target=request.target,
                target_tris=tris[0][k],
                tool_tris=tris[1][k],
                view=Rect(vx0, vx1, vy0, vy1),
                texel_view=Rect(*values[18:22]),
                texel_slab=(lo, hi),
                tool_slab=(tool_s, np.inf) if request.tool_list else None,
                fields={
                    "eye": np.array(values[15:18]),
                    "right": frame[0],
                    "up": frame[1],
                    "forward": frame[2],
                    "half_extent": (hx, hy),
                    "depth_range": (0.0, depth),
                    "resolution": (int(nx), int(ny)),
                    "slab": (near, far),
                    "texel_metres": texel_k,
                },
            )
        )
    return drafts


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
    lists = iter(lists_many(queries, exact_lists))
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
