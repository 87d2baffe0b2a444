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

from dentdemo.carve.constants import MIN_COS, RING_TEXELS, SLAB_MARGIN_TEXELS
from dentdemo.carve.footprint import Overlap, Projected, Query, Rect, meeting_many, overlap
from dentdemo.carve.linear import column_scale
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
    """`camera_draft` of each request, worked out for all of them together: their camera
    frames (`_frames`), then each one's footprint bound (`footprint.overlap`), then the
    lattices, depth ranges and slabs of those whose bodies can meet (`_views`), each step one
    array expression over every direction."""
    if not requests:
        return []
    frames = _frames(requests)
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
        for one, draft in zip(posed, _views(requests, frames, posed, max_resolution), strict=True):
            drafts[one.at] = draft
    return drafts


class _Frames(NamedTuple):
    """The camera frames of a batch's directions (world metres): axes (n, 3, 3: right, up,
    forward as rows), origins (n, 3: the centre of the target texel under each contact), the
    target's texel sides along u and v (n, 2) and the pixel pitches along x and y (n, 2,
    before the lattice)."""

    axes: NDArray[np.float64]
    origin: NDArray[np.float64]
    texel: NDArray[np.float64]
    pitch: NDArray[np.float64]


class _Posed(NamedTuple):
    """A direction whose bodies can meet: its index in the batch, both bodies in its camera's
    coordinates and the bound of their overlap."""

    at: int
    target_tris: Projected
    tool_tris: Projected
    bound: Overlap


def _py_max(a: NDArray[np.float64], b: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """Python's max(a, b) elementwise (b only where greater: of 0.0 and -0.0, a)."""
    return np.where(b > a, b, a)


def _py_min(a: NDArray[np.float64], b: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """Python's min(a, b) elementwise (b only where less)."""
    return np.where(b < a, b, a)


def _views(
    requests: Sequence[DraftRequest],
    frames: _Frames,
    posed: list[_Posed],
    max_resolution: int,
) -> list[CameraDraft]:
    """The drafts of the directions `posed` (each with its bound) of `requests`: each one's
    lattice of pixels over its bound, depth range and slabs, one array expression per step
    over all of them (the arithmetic one direction had on Python floats, in the same order:
    the same bits). Pairs of x and y quantities are (m, 2) arrays."""
    index = np.array([one.at for one in posed])
    bounds = np.array(
        [
            (b.rect.x0, b.rect.x1, b.rect.y0, b.rect.y1, *b.slab)
            for b in (one.bound for one in posed)
        ]
    )
    low, high, slab = bounds[:, 0:4:2], bounds[:, 1:4:2], bounds[:, 4:]
    texel_uv, pitch = frames.texel[index], frames.pitch[index]
    texel = np.maximum(texel_uv[:, 0], texel_uv[:, 1])
    margin = (2.0 * texel + np.maximum(pitch[:, 0], pitch[:, 1]))[:, None]
    low, high = low - margin, high + margin
    # Pixel centres at whole multiples of the pitch from the origin; beyond `max_resolution`
    # pixels a side, fewer larger ones over the same span.
    k0, k1 = np.floor(low / pitch), np.ceil(high / pitch)
    count = k1 - k0 + 1
    capped = count > max_resolution
    centre = np.where(capped, (low + high) / 2, (k0 + k1) / 2 * pitch)
    pitch = np.where(capped, (high - low) / (max_resolution - 1), pitch)
    count = np.where(capped, max_resolution, count)
    half = count * pitch / 2.0
    # Depth range: everything of both bodies, so that nothing in front of the target is
    # clipped. Heights: each body's (max_height, max_dent_depth), target first.
    s = np.array([(*one.target_tris.s_range(), *one.tool_tris.s_range()) for one in posed])
    heights = np.array(
        [
            (r.target.max_height, r.target.max_dent_depth, r.tool.max_height, r.tool.max_dent_depth)
            for r in (requests[one.at] for one in posed)
        ]
    )
    proud_each = _py_max(heights, 0.0)
    bumps = 0 + (proud_each[:, 0] + proud_each[:, 1]) + (proud_each[:, 2] + proud_each[:, 3])
    near_s = _py_min(s[:, 0], s[:, 2]) - bumps - 1e-4
    far_s = _py_max(s[:, 1], s[:, 3]) + bumps + 1e-4
    axes = frames.axes[index]
    eye = (
        frames.origin[index]
        + axes[:, 0] * centre[:, 0, None]
        + axes[:, 1] * centre[:, 1, None]
        + axes[:, 2] * near_s[:, None]
    )
    # A built-in sphere or capsule is dented at its texels' points on the smooth solid but
    # clipped at their facet points, which lie up to its facet sag deeper (mesh.facet_sag).
    sag = np.array(
        [
            r.target.mesh.facet_sag() * column_scale(np.asarray(r.target.model)[:3, :3])
            for r in (requests[one.at] for one in posed)
        ]
    )
    gather_lo = slab[:, 0] - SLAB_MARGIN_TEXELS * texel
    gather_hi = slab[:, 1] + SLAB_MARGIN_TEXELS * texel + sag
    ring = RING_TEXELS * texel
    proud = proud_each[:, 0] + proud_each[:, 2]
    # Pass 2 sees the target from the slab's near side on (a nearer surface lies behind the
    # tool: it neither hides the slab nor takes a dent), up to its far side. Pass 3 draws the
    # tool's faces that reach past the slab's near side (two pixels more for the bilinear
    # neighbours at the rim): a front face nearer than that is nearer than every target
    # surface pass 2 keeps, so leaving it out drops nothing that pass 2 or 4 would test
    # against it.
    tool_near = gather_lo - proud - 2.0 * np.maximum(pitch[:, 0], pitch[:, 1])
    columns = zip(
        (centre - half).tolist(),
        (centre + half).tolist(),
        half.tolist(),
        count.astype(np.int64).tolist(),
        texel.tolist(),
        (gather_lo - ring).tolist(),
        (gather_hi + ring).tolist(),
        tool_near.tolist(),
        (far_s - near_s).tolist(),
        (gather_lo - near_s).tolist(),
        (gather_hi - near_s).tolist(),
        strict=True,
    )
    drafts = []
    for one, eye_k, (lo, hi, (half_x, half_y), cols, texel_k, *slabs, depth, near, far) in zip(
        posed, eye, columns, strict=True
    ):
        request = requests[one.at]
        view = Rect(lo[0], hi[0], lo[1], hi[1])
        frame = frames.axes[one.at]
        drafts.append(
            CameraDraft(
                target=request.target,
                target_tris=one.target_tris,
                tool_tris=one.tool_tris,
                view=view,
                texel_view=texel_rect(request.target, one.bound.rect, 2.0 * texel_k, view),
                texel_slab=(slabs[0], slabs[1]),
                tool_slab=(slabs[2], np.inf) if request.tool_list else None,
                fields={
                    "eye": eye_k,
                    "right": frame[0],
                    "up": frame[1],
                    "forward": frame[2],
                    "half_extent": (half_x, half_y),
                    "depth_range": (0.0, depth),
                    "resolution": (cols[0], cols[1]),
                    "slab": (near, far),
                    "texel_metres": texel_k,
                },
            )
        )
    return drafts


def _dot(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """dot3 of the vectors along the last axis of `a` and `b`, summed in dot3's order."""
    p = a * b
    return p[..., 0] + p[..., 1] + p[..., 2]


def _matrix_rows(m: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """rows_times of each (3, 3) `m` (n, 3, 3) and its vector `v` (n, 3)."""
    return _dot(m, v[:, None, :])


def _cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """cross3 of the vectors along the last axis of `a` and `b` (component k: a[k+1] b[k+2]
    less a[k+2] b[k+1])."""
    return a[..., _NEXT] * b[..., _AFTER] - a[..., _AFTER] * b[..., _NEXT]


#: Each component's next and the one after (cyclic): the cross product's factors.
_NEXT, _AFTER = [1, 2, 0], [2, 0, 1]


def _unit_rows(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """`_unit` of rows (n, 3)."""
    return v * (1.0 / np.maximum(np.sqrt(_dot(v, v)), 1e-30))[:, None]


def _across_rows(v: NDArray[np.float64], unit: NDArray[np.float64]) -> NDArray[np.float64]:
    """`_across` of rows (n, 3)."""
    return v - _dot(v, unit)[:, None] * unit


def _inverses(m: NDArray[np.float64]) -> NDArray[np.float64]:
    """`linear.inverse3` of each (3, 3) `m` (n, 3, 3): the same cofactors (row k of the
    adjugate is the cross product of columns k + 1 and k + 2), the same determinant."""
    columns = m.transpose(0, 2, 1)
    adjugate = _cross(columns[:, _NEXT], columns[:, _AFTER])
    det = _dot(m[:, 0], adjugate[:, :, 0])
    if ((det == 0.0) | (det != det)).any():
        raise ValueError("singular 3x3 matrix")
    return adjugate * (1.0 / det)[:, None, None]


def _frames(requests: Sequence[DraftRequest]) -> _Frames:
    """The camera frame of every request, each step one array expression over all of them: the
    arithmetic of one direction on Python floats, in the same order, so the same bits (where
    Python's max would pick one of two equal values, they are the same float here). The view
    looks along the press; `right` follows the target's +u tangent at the contact, its pitch
    the target's texel as the camera sees it, a pixel spanning a whole number of target
    texels up to one of the tool's, and the origin is the centre of the target texel under
    the contact. Pairs of u and v quantities are (n, 2) arrays."""
    models = np.array([r.target.model for r in requests], dtype=np.float64)
    linear = models[:, :3, :3]
    forward = _unit_rows(np.array([r.contact.direction for r in requests], dtype=np.float64))
    point = np.array([r.contact.point for r in requests], dtype=np.float64)
    local = _matrix_rows(_inverses(linear), point - models[:, :3, 3])
    # Each target's triangle near the contact (a mesh's own look-up), its uv extended to it.
    surfs = [r.target.mesh.frame_near(p) for r, p in zip(requests, local, strict=True)]
    uv = np.array([s.uv for s in surfs], dtype=np.float64)
    # World metres per unit of u and of v (n, 2, 3).
    local_tangents = np.array([(s.dpdu, s.dpdv) for s in surfs], dtype=np.float64)
    tangents = _dot(linear[:, None], local_tangents[:, :, None])
    lengths = np.sqrt(_dot(tangents, tangents))
    size = np.array([r.map_size for r in requests], dtype=np.float64)
    # `_axes`: right along dP/du across the view, or a fixed axis where dP/du is along it.
    right = _across_rows(tangents[:, 0], forward)
    along = np.sqrt(_dot(right, right)) < 1e-9 * np.maximum(lengths[:, 0], 1e-30)
    if along.any():
        fixed = np.where((np.abs(forward[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
        right = np.where(along[:, None], _across_rows(fixed, forward), right)
    right = _unit_rows(right)
    up = _cross(right, forward)
    # Texel pitch as the camera sees it (x from u, y from v), metres; grazing views are clamped.
    texel = lengths / size
    seen = np.abs(_dot(tangents, np.concatenate((right[:, None], up[:, None]), axis=1))) / size
    pitch = np.maximum(seen, MIN_COS * texel)
    # The tool is known to its own texels only: where the target's texels are finer, a pixel
    # spans a whole number of them (pixel centres stay on texel centres) up to one of the
    # tool's texels.
    tool_texel = np.array([r.tool.texel_metres for r in requests], dtype=np.float64)
    pitch = pitch * np.maximum(np.floor(tool_texel[:, None] / pitch), 1.0)
    # A pixel centre on the centre of the texel under the contact.
    shift = (np.floor(uv * size) + 0.5) / size - uv
    origin = point + tangents[:, 0] * shift[:, 0, None] + tangents[:, 1] * shift[:, 1, None]
    axes = np.concatenate((right[:, None], up[:, None], forward[:, None]), axis=1)
    return _Frames(axes, origin, texel, pitch)


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
