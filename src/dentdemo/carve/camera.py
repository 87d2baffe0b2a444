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
from dentdemo.carve.footprint import Overlap, Projected, Query, Rect, meeting_many, overlap
from dentdemo.carve.linear import column_scale, cross3, dot3, inverse_rows, rows_times
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


class _Posed(NamedTuple):
    """A direction whose bodies can meet: its index in the batch, both bodies in its camera's
    coordinates and the bound of their overlap."""

    at: int
    target_tris: Projected
    tool_tris: Projected
    bound: Overlap


def _drafts(
    requests: Sequence[DraftRequest],
    max_resolution: int,
    loose: bool,
    mode: lanes.Mode,
) -> list[CameraDraft | None]:
    """`camera_drafts` of `requests`, their frames and views worked out in lanes made by
    `mode`."""
    frames = _frames(requests, mode)
    posed: list[_Posed] = []
    for k, (target, tool, _, _, advance, _) in enumerate(requests):
        target_tris = Projected(target.mesh, target.model, frames.origin[k], frames.axes[k])
        tool_tris = Projected(tool.mesh, tool.model, frames.origin[k], frames.axes[k])
        bound = overlap(target_tris, tool_tris, target.max_height, tool.max_height, advance)
        if bound is not None:
            if loose:
                bound = _loose(target_tris, tool_tris, bound)
            posed.append(_Posed(k, target_tris, tool_tris, bound))
    drafts: list[CameraDraft | None] = [None] * len(requests)
    if posed:
        views = _views(requests, frames, posed, max_resolution, mode)
        for one, draft in zip(posed, views, strict=True):
            drafts[one.at] = draft
    return drafts


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
        axes, origins = [np.array([right, up, forward])], [np.array(origin)]
    else:
        stacked = np.array([right, up, forward]).transpose(2, 0, 1)
        axes, origins = list(np.ascontiguousarray(stacked)), list(np.array(origin).T.copy())
    return _Frames(axes, origins, (texel_u, texel_v), (pitch_x, pitch_y))


def _views(
    requests: Sequence[DraftRequest],
    frames: _Frames,
    posed: list[_Posed],
    max_resolution: int,
    mode: lanes.Mode,
) -> list[CameraDraft]:
    """The drafts of the directions `posed` (each with its bound) of `requests`: each one's
    lattice of pixels over its bound, depth range and slabs, one expression per step over the
    lanes (`lanes.Lane`)."""
    at = [one.at for one in posed]
    # The frames' lanes, of the directions posed.
    texel_u, texel_v, pitch_x, pitch_y = (
        x[at] if isinstance(x, np.ndarray) else x for x in (*frames.texel, *frames.pitch)
    )
    x0, x1, y0, y1, slab_lo, slab_hi = mode.columns(
        [(b.rect.x0, b.rect.x1, b.rect.y0, b.rect.y1, *b.slab) for b in (p.bound for p in posed)]
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
    target_lo, target_hi, tool_lo, tool_hi = mode.columns(
        [(*one.target_tris.s_range(), *one.tool_tris.s_range()) for one in posed]
    )
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
    axes = [frames.axes[k] for k in at]
    flat = mode.columns([a.ravel().tolist() for a in axes])
    right, up, forward = flat[0:3], flat[3:6], flat[6:9]
    origin = mode.columns([frames.origin[k].tolist() for k in at])
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
    outputs = (
        cx - half_x,
        cx + half_x,
        cy - half_y,
        cy + half_y,
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
    )
    columns = mode.rows(outputs)
    drafts = []
    for one, frame, values in zip(posed, axes, columns, strict=True):
        (vx0, vx1, vy0, vy1, hx, hy, nx, ny, texel_k, lo, hi, tool_s, depth, near, far) = values[
            :15
        ]
        request = requests[one.at]
        view = Rect(vx0, vx1, vy0, vy1)
        drafts.append(
            CameraDraft(
                target=request.target,
                target_tris=one.target_tris,
                tool_tris=one.tool_tris,
                view=view,
                texel_view=texel_rect(request.target, one.bound.rect, 2.0 * texel_k, view),
                texel_slab=(lo, hi),
                tool_slab=(tool_s, np.inf) if request.tool_list else None,
                fields={
                    "eye": np.array(values[15:]),
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
