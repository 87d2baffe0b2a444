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
    """`camera_draft` of each request, the camera frames of all of them worked out together
    (`_frames`: one array expression per step over every direction); then each one's bound."""
    if not requests:
        return []
    frames = _frames(requests)
    return [
        _draft(request, frame, max_resolution, loose)
        for request, frame in zip(requests, frames, strict=True)
    ]


class _Frame(NamedTuple):
    """A direction's camera frame (world metres): axes (right, up, forward as rows), the
    origin (the centre of the target texel under the contact), the target's texel sides along
    u and v and the pixel pitches (before the lattice)."""

    axes: NDArray[np.float64]
    origin: tuple[float, float, float]
    texel_u: float
    texel_v: float
    pitch_x: float
    pitch_y: float


def _dot(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """dot3 of the vectors along the last axis of `a` and `b`, summed in dot3's order."""
    p = a * b
    return p[..., 0] + p[..., 1] + p[..., 2]


def _matrix_rows(m: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """rows_times of each (3, 3) `m` (n, 3, 3) and its vector `v` (n, 3)."""
    return _dot(m, v[:, None, :])


def _cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """cross3 of the vectors along the last axis of `a` and `b`."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


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
    adjugate = _cross(columns[:, [1, 2, 0]], columns[:, [2, 0, 1]])
    det = _dot(m[:, 0], adjugate[:, :, 0])
    if ((det == 0.0) | (det != det)).any():
        raise ValueError("singular 3x3 matrix")
    return adjugate * (1.0 / det)[:, None, None]


def _frames(requests: Sequence[DraftRequest]) -> list[_Frame]:
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
    seen = np.abs(_dot(tangents, np.stack([right, up], axis=1))) / size
    pitch = np.maximum(seen, MIN_COS * texel)
    # The tool is known to its own texels only: where the target's texels are finer, a pixel
    # spans a whole number of them (pixel centres stay on texel centres) up to one of the
    # tool's texels.
    tool_texel = np.array([r.tool.texel_metres for r in requests], dtype=np.float64)
    pitch = pitch * np.maximum(np.floor(tool_texel[:, None] / pitch), 1.0)
    # A pixel centre on the centre of the texel under the contact.
    shift = (np.floor(uv * size) + 0.5) / size - uv
    origin = point + tangents[:, 0] * shift[:, 0, None] + tangents[:, 1] * shift[:, 1, None]
    axes = np.stack([right, up, forward], axis=1)
    return [
        _Frame(frame, (o[0], o[1], o[2]), t[0], t[1], p[0], p[1])
        for frame, o, t, p in zip(
            axes, origin.tolist(), texel.tolist(), pitch.tolist(), strict=True
        )
    ]


def _draft(
    request: DraftRequest, frame: _Frame, max_resolution: int, loose: bool
) -> CameraDraft | None:
    """One direction's draft from its frame: the footprint bound, the lattice of pixels, the
    depth range and slabs."""
    target, tool, _, _, advance, tool_list = request
    model = np.asarray(target.model, dtype=np.float64)
    linear = model[:3, :3]
    axes, origin = frame.axes, frame.origin
    right, up, forward = (axes[0].tolist(), axes[1].tolist(), axes[2].tolist())
    texel_u, texel_v, pitch_x, pitch_y = frame.texel_u, frame.texel_v, frame.pitch_x, frame.pitch_y
    at = np.array(origin)
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
