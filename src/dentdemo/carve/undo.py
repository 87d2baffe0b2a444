"""Undo and repair of the carve (docs/carve.md, "Undo and repair").

Before a batch of hits is carved (`Carver.carve_hits`), `UndoLog.record` copies every map
rectangle the batch may write, heights (R32F) and normals (RGBA8), into textures of its own on the
GPU: glBlitFramebuffer between textures of the same format and size, NEAREST (exact), no
readback. `UndoLog.undo` copies the last batch's rectangles back. One entry is one call of
`carve_hits`: one press (both directions), one `press_many`, or one frame's queue in the sandbox,
so that undo is bit-exact (every hit of a batch reads the heights from before the batch, so a
single hit of a batch cannot be taken back alone). The log keeps at most `depth` entries and
`budget` bytes of texels, dropping the oldest; a batch whose snapshots alone exceed `budget` is
carved unrecorded, with one UndoWarning, and the entries before it stay.

Where a map's rectangles come from: passes 4 and 5 draw only the triangles `camera.target_texels`
and `camera.target_gutter` (a subset of the first) in texture space; the first write texel centres
inside those triangles, the gutter draws (texel.geom) each triangle's texel bounding box grown by
one texel. So every texel a job writes lies inside its triangles' uv bounding boxes grown by
`MARGIN` texels. Those boxes within one chart (`Mesh.triangle_charts`) give their bounding box
(the footprint's triangles in a chart join edge to edge, so merging their boxes gives no other;
a footprint that falls apart inside one chart gets the box around both parts), and the boxes of
all jobs on one map are merged into a few rectangles (split where `GAP` texels or more of rows or
columns hold no box, so that a dent across two far charts of an atlas keeps two small
rectangles). A flat target's boxes are cut to its texels in the view rectangle (`view_box`): a
plate's triangles are few and large (the ground's span 64 texels of its 512^2 map each), and
the sandbox's last 64 batches held 42 MB of snapshots with whole triangles' boxes, 8.5 MB
without.

Where the snapshots live: an entry's rectangles are packed side by side (`packed`: shelves,
tallest first) into one pair of textures (height, normals) whose sides are the packing's rounded
up to a size class (`size_class`: 16, 24, 32, 48, 64, 96, ... texels), so that the pairs of
dropped entries serve the next ones instead of being deleted and made again. Making a pair
costs more than copying into it: one pair a batch, not one a rectangle (a sandbox frame's batch
has about six), and the copies into it follow each other (every height, then every normal).
The log counts the pairs' texture bytes against its budget; pairs kept idle for reuse are at
most `IDLE_BYTES`.
"""

from __future__ import annotations

import ctypes
import math
import warnings
from collections import deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import moderngl
import numpy as np
from numpy.typing import NDArray

from dentdemo.carve.linear import cross3, dot3, inverse3, rows_times
from dentdemo.carve.surface import flatten, rebuild_all_normals
from dentdemo.errors import UndoWarning
from dentdemo.gl.context import GLContext, release
from dentdemo.gl.library import gl_library
from dentdemo.gl.state import preserved
from dentdemo.gpu.maps import SurfaceMaps
from dentdemo.gpu.mesh import GpuMesh

if TYPE_CHECKING:
    from dentdemo.carve.carver import CarveJob
    from dentdemo.mesh.mesh import Mesh

#: Entries (batches of hits) the log keeps at most; the oldest is dropped first.
UNDO_DEPTH = 64
#: Bytes of snapshot texels the log keeps at most (texture memory: 8 bytes a texel).
UNDO_BYTES = 64 << 20
#: Bytes a snapshot texel takes: R32F height (4) + RGBA8 normal (4).
SNAPSHOT_BYTES_PER_TEXEL = 4 + 4
#: Texels added on each side of a triangle's uv bounding box: the gutter draw grows it by one
#: texel (texel.geom), one more for the rounding of the box's corners.
MARGIN = 2
#: Boxes farther apart than this (texels) along u or v get rectangles of their own.
GAP = 8
#: Bytes of snapshot textures the log keeps idle for reuse at most (beside its budget).
IDLE_BYTES = 8 << 20
#: The smallest side of a snapshot texture, texels.
MIN_SIDE = 16


def size_class(side: int) -> int:
    """A snapshot texture's side for a rectangle's `side` (texels): the least of 16, 24, 32, 48,
    64, 96, ... (powers of two and 1.5 times them) that holds it, so at most 1.5 times it past
    16."""
    if side <= MIN_SIDE:
        return MIN_SIDE
    power = 1 << (side - 1).bit_length()  # the least power of two >= side
    return power * 3 // 4 if side <= power * 3 // 4 else power


#: A rectangle of a map: (x, y, width, height), texels; x along +u, y along +v (row 0 is v = 0).
Rect = tuple[int, int, int, int]
#: A box of texels: (x0, y0, x1, y1), half-open.
Box = tuple[int, int, int, int]
#: Either side of a copy: a map's framebuffer, or a snapshot texture.
Side = moderngl.Framebuffer | moderngl.Texture
#: One copy: (what is read, its lower-left texel, what is written, its lower-left texel, width,
#: height).
Copy = tuple[Side, tuple[int, int], Side, tuple[int, int], int, int]

_READ_FRAMEBUFFER, _DRAW_FRAMEBUFFER, _FRAMEBUFFER = 0x8CA8, 0x8CA9, 0x8D40
_COLOR_ATTACHMENT0, _TEXTURE_2D = 0x8CE0, 0x0DE1
_COLOR_BUFFER_BIT, _NEAREST = 0x4000, 0x2600


def chart_boxes(
    mesh: Mesh, triangles: NDArray[np.integer], size: tuple[int, int], margin: int = MARGIN
) -> list[Box]:
    """For each chart (`Mesh.triangle_charts`) that `triangles` meet, the bounding box of their
    texel boxes there: each triangle's uv bounding box in texels, grown by `margin`, clamped to
    the map; (x0, y0, x1, y1), half-open, in the charts' order, none where it is empty. With
    margin 0 it holds every texel whose centre lies in one of the triangles."""
    if len(triangles) == 0:
        return []
    which = np.asarray(triangles)
    bounds = mesh.triangle_uv_bounds().take(which, axis=1)  # (4, k)
    charts = mesh.triangle_charts().take(which)
    if charts.min() == charts.max():  # one chart (most presses)
        parts = [[*bounds[:2].min(axis=1).tolist(), *bounds[2:].max(axis=1).tolist()]]
    else:
        order = np.argsort(charts, kind="stable")
        bounds, charts = bounds[:, order], charts[order]
        starts = np.flatnonzero(np.concatenate([[True], charts[1:] != charts[:-1]]))
        low = np.minimum.reduceat(bounds[:2], starts, axis=1)
        high = np.maximum.reduceat(bounds[2:], starts, axis=1)
        parts = np.concatenate([low, high]).T.tolist()
    w, h = size
    out: list[Box] = []
    for u0, v0, u1, v1 in parts:  # a few: on Python floats
        tight = (math.floor(u0 * w), math.floor(v0 * h), math.ceil(u1 * w), math.ceil(v1 * h))
        x0, y0, x1, y1 = grown(tight, margin, size)
        if x1 > x0 and y1 > y0:
            out.append((x0, y0, x1, y1))
    return out


def grown(box: Box, margin: int, size: tuple[int, int]) -> Box:
    """`box` grown by `margin` texels on each side, clamped to a map of `size`."""
    x0, y0, x1, y1 = box
    w, h = size
    return (
        min(max(x0 - margin, 0), w),
        min(max(y0 - margin, 0), h),
        min(max(x1 + margin, 0), w),
        min(max(y1 + margin, 0), h),
    )


def footprint_boxes(job: CarveJob) -> list[Box]:
    """`chart_boxes` of the triangles passes 4 and 5 draw for `job`, with no margin: the texels
    whose centres lie in them, per chart (computed once per camera)."""
    cam = job.camera
    boxes = cam.derived.get("boxes")
    if boxes is None:
        size = job.target.maps.size
        boxes = chart_boxes(job.target.gpu_mesh.mesh, cam.target_texels, size, margin=0)
        cam.derived["boxes"] = boxes
    return boxes  # type: ignore[return-value]


def merged_rects(boxes: NDArray[np.int64] | Sequence[Sequence[int]], gap: int = GAP) -> list[Rect]:
    """Disjoint rectangles that together hold every box (x0, y0, x1, y1): the boxes split into
    groups along a row or column band that no box touches and that is at least `gap` texels
    wide (again within each group, rows first), each group's bounding box one rectangle. On
    Python ints: a batch gives a few boxes a map (one a chart a job meets)."""
    rows = boxes.tolist() if isinstance(boxes, np.ndarray) else boxes
    out: list[Rect] = []
    if len(rows):
        _split([(int(a), int(b), int(c), int(d)) for a, b, c, d in rows], gap, out)
    return out


def _split(boxes: list[Box], gap: int, out: list[Rect]) -> None:
    for axis in (1, 0):  # along v (rows), then along u (columns)
        ordered = sorted(boxes, key=lambda box: box[axis])  # stable
        groups: list[list[Box]] = [[ordered[0]]]
        reach = ordered[0][axis + 2]  # the farthest end of the boxes so far
        for box in ordered[1:]:
            if box[axis] >= reach + gap:
                groups.append([])
            groups[-1].append(box)
            reach = max(reach, box[axis + 2])
        if len(groups) > 1:
            for group in groups:
                _split(group, gap, out)
            return
    x0, y0 = min(b[0] for b in boxes), min(b[1] for b in boxes)
    x1, y1 = max(b[2] for b in boxes), max(b[3] for b in boxes)
    out.append((x0, y0, x1 - x0, y1 - y0))


def view_box(job: CarveJob) -> Box | None:
    """For a flat target (`Mesh.is_flat`: a plate), the box of the texels whose points on its
    plane lie in the job's view rectangle seen along the press (x0, y0, x1, y1, half-open, not
    clamped to the map); None for another target, or a view that grazes the plane. Passes 4
    and 5 clip every texel they write to that rectangle (clip.glsl), and the plane's uv is one
    affine map, so the rectangle's image in the map is a parallelogram whose box holds them: a
    plate's few large triangles otherwise snapshot most of its map for a dent of a few texels."""
    mesh = job.target.gpu_mesh.mesh
    if not mesh.is_flat():
        return None
    cam = job.camera
    model = np.asarray(job.target.model, dtype=np.float64)
    local = inverse3(model[:3, :3]).tolist()  # local from world, linear part: rows
    dpdu, dpdv = (d[0].tolist() for d in mesh.triangle_derivatives())  # local m per uv unit
    normal = cross3(dpdu, dpdv)
    forward = rows_times(local, cam.forward.tolist())
    along = dot3(normal, forward)
    if abs(along) <= 1e-6 * math.sqrt(dot3(normal, normal) * dot3(forward, forward)):
        return None  # grazing: the parallelogram is unbounded
    # uv is affine on the plane: the eye moved along the press onto it (through the first
    # triangle's first corner) gives the rectangle's centre, and the view's right and up moved
    # the same way its half sides. On Python floats: a few scalars (numpy costs more a call).
    vertex = int(mesh.indices[0, 0])
    anchor = mesh.positions[vertex].tolist()
    guu, guv, gvv = dot3(dpdu, dpdu), dot3(dpdu, dpdv), dot3(dpdv, dpdv)
    det = guu * gvv - guv * guv

    def onto(v: Sequence[float], point: bool) -> tuple[float, float]:
        """The uv offset (from the anchor's) of local point or direction `v` moved along the
        press onto the plane: v + s forward - anchor = a dpdu + b dpdv (normal equations)."""
        rel = [x - a for x, a in zip(v, anchor, strict=True)] if point else v
        s = -dot3(normal, rel) / along
        x = [r + s * f for r, f in zip(rel, forward, strict=True)]
        bu, bv = dot3(x, dpdu), dot3(x, dpdv)
        return (gvv * bu - guv * bv) / det, (guu * bv - guv * bu) / det

    eye = [e - t for e, t in zip(cam.eye.tolist(), model[:3, 3].tolist(), strict=True)]
    cu, cv = onto(rows_times(local, eye), True)
    ru, rv = onto(rows_times(local, cam.right.tolist()), False)
    wu, wv = onto(rows_times(local, cam.up.tolist()), False)
    hx, hy = cam.half_extent
    su, sv = hx * abs(ru) + hy * abs(wu), hx * abs(rv) + hy * abs(wv)
    u0, v0 = mesh.uvs[vertex].tolist()
    w, h = job.target.maps.size
    return (
        math.floor((u0 + cu - su) * w),
        math.floor((v0 + cv - sv) * h),
        math.ceil((u0 + cu + su) * w),
        math.ceil((v0 + cv + sv) * h),
    )


def _intersected(a: Box, b: Box) -> Box | None:
    x0, y0, x1, y1 = max(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), min(a[3], b[3])
    return (x0, y0, x1, y1) if x1 > x0 and y1 > y0 else None


def job_rects(jobs: Sequence[CarveJob]) -> list[tuple[SurfaceMaps, list[Rect]]]:
    """The maps the jobs write and, for each, the rectangles holding every texel written."""
    by_maps: dict[int, tuple[SurfaceMaps, list[Box]]] = {}
    for job in jobs:
        maps = job.target.maps
        # The gutter's triangles are among the texels' (`collision_cameras`): so are their boxes.
        found: list[Box] = footprint_boxes(job)
        view = view_box(job)
        if view is not None:  # and a flat target's texels in its view's
            found = [box for box in (_intersected(box, view) for box in found) if box]
        boxes = [grown(box, MARGIN, maps.size) for box in found]
        by_maps.setdefault(id(maps), (maps, []))[1].extend(boxes)
    return [(maps, merged_rects(found)) for maps, found in by_maps.values()]


@dataclass(frozen=True)
class SnapshotTextures:
    """A pair of snapshot textures of one size (texels). They have no framebuffers of their
    own: a copy attaches them to one of the log's two (`UndoLog._blit`)."""

    size: tuple[int, int]
    height: moderngl.Texture
    normal: moderngl.Texture

    @property
    def bytes(self) -> int:
        return self.size[0] * self.size[1] * SNAPSHOT_BYTES_PER_TEXEL

    def release(self) -> None:
        release(self.height, self.normal)


@dataclass
class Snapshot:
    """One rectangle of a map's height and normals as they were before an entry's hits, at
    `at` (its lower-left texel) in the entry's pair of textures."""

    maps: SurfaceMaps
    rect: Rect
    at: tuple[int, int]


@dataclass
class Entry:
    """One batch's snapshots, packed side by side in one pair of textures (iterating an entry
    gives its snapshots)."""

    snapshots: list[Snapshot]
    textures: SnapshotTextures

    def __iter__(self) -> Iterator[Snapshot]:
        return iter(self.snapshots)

    def __len__(self) -> int:
        return len(self.snapshots)

    @property
    def bytes(self) -> int:
        """The texture bytes the entry holds (its pair's size class, not only its rectangles)."""
        return self.textures.bytes


def packed(sides: Sequence[tuple[int, int]]) -> tuple[list[tuple[int, int]], tuple[int, int]]:
    """Rectangles of `sides` (width, height, texels) placed side by side without overlap: each
    one's lower-left texel, and the width and height that hold them all. Shelves left to
    right, bottom to top, the tallest first, about as wide as the square of their area."""
    if not sides:
        return [], (0, 0)
    area = sum(w * h for w, h in sides)
    width = max(max(w for w, _ in sides), math.isqrt(area - 1) + 1)
    at: list[tuple[int, int]] = [(0, 0)] * len(sides)
    x = y = shelf = used = 0
    for k in sorted(range(len(sides)), key=lambda k: -sides[k][1]):  # stable: ties in order
        w, h = sides[k]
        if x + w > width:
            x, y, shelf = 0, y + shelf, 0
        at[k] = (x, y)
        x, shelf = x + w, max(shelf, h)
        used = max(used, x)
    return at, (used, y + shelf)


class UndoLog:
    """The snapshots of the last `depth` batches of hits, at most `budget` bytes in all, on the
    GPU (see the module's docstring). Undo past the oldest kept entry is a no-op returning
    False. A batch whose snapshots alone exceed the budget is not recorded, with an UndoWarning
    saying so (and `unrecorded` counting it); the entries before it are kept, and undoing them
    puts their texels back as they were before them, that batch's dents among them too."""

    def __init__(self, gl: GLContext, depth: int = UNDO_DEPTH, budget: int = UNDO_BYTES) -> None:
        self.gl = gl
        self.depth = depth
        self.budget = budget
        #: Oldest first; each entry is the snapshots of one batch.
        self.entries: deque[Entry] = deque()
        #: Texture bytes of the entries' pairs.
        self.bytes = 0
        #: Texture pairs of dropped entries by size, for reuse; `idle_bytes` in all.
        self._idle: dict[tuple[int, int], list[SnapshotTextures]] = {}
        self.idle_bytes = 0
        #: Batches not recorded because their snapshots alone exceed the budget.
        self.unrecorded = 0
        #: The framebuffers a copy attaches snapshot textures to (read, draw; made when first
        #: needed).
        self._fbos: tuple[int, int] | None = None

    def __len__(self) -> int:
        return len(self.entries)

    def record(self, hits: Sequence[Sequence[CarveJob]]) -> None:
        """Snapshot what the batch `hits` will write, as one entry, before any of its passes
        runs. Called inside `preserved` (by `Carver.carve_hits`)."""
        jobs = [job for hit in hits for job in hit]
        if not jobs or self.depth <= 0:
            return
        rects = [(maps, rect) for maps, found in job_rects(jobs) for rect in found]
        if not rects:
            return
        at, (width, height) = packed([(w, h) for _, (_, _, w, h) in rects])
        size = (size_class(width), size_class(height))
        needed = size[0] * size[1] * SNAPSHOT_BYTES_PER_TEXEL
        if needed > self.budget:
            # Recording it would mean dropping every older entry and still going over the
            # budget: the call is not recorded, the history before it is kept, and it is said.
            self.unrecorded += 1
            warnings.warn(
                f"undo: this call's snapshots would take {_kib(needed)}, over the undo budget "
                f"of {_kib(self.budget)}: it is carved but cannot be undone; the "
                f"{len(self.entries)} calls before it stay in the history",
                UndoWarning,
                stacklevel=2,
            )
            return
        while self.entries and (
            len(self.entries) >= self.depth or self.bytes + needed > self.budget
        ):
            self._drop(self.entries.popleft())
        entry = Entry(
            [Snapshot(maps, rect, xy) for (maps, rect), xy in zip(rects, at, strict=True)],
            self._pair(size),
        )
        self._blit(_snapshot_copies(entry))
        self.entries.append(entry)
        self.bytes += needed

    def undo(self) -> bool:
        """Put back the maps as they were before the last recorded batch; False (nothing done)
        when the log is empty. The host's GL state is left as it was."""
        if not self.entries:
            return False
        entry = self.entries.pop()
        # Record's copies the other way (the rectangles of one entry and map are disjoint: any
        # order would do).
        copies: list[Copy] = [
            (target, at, source, xy, w, h)
            for source, xy, target, at, w, h in _snapshot_copies(entry)
        ]
        with preserved(self.gl.ctx):
            self._blit(copies)
            wait_for_writes(self.gl)
        self._drop(entry)
        return True

    def forget(self, maps: SurfaceMaps) -> None:
        """Drop every snapshot of `maps` (its maps were replaced: repair, new heights, release);
        entries left empty go. Undo then restores the other bodies of those entries only."""
        kept: deque[Entry] = deque()
        for entry in self.entries:
            entry.snapshots = [snap for snap in entry if snap.maps is not maps]
            if entry.snapshots:
                kept.append(entry)
            else:
                self._drop(entry)
        self.entries = kept

    def clear(self) -> None:
        while self.entries:
            self._drop(self.entries.popleft())

    def release(self) -> None:
        """Every snapshot and idle texture deleted, and the framebuffers of the copies."""
        self.clear()
        if self._fbos is not None:
            gl_library().glDeleteFramebuffers(2, (ctypes.c_uint * 2)(*self._fbos))
            self._fbos = None
        for pairs in self._idle.values():
            for pair in pairs:
                pair.release()
        self._idle.clear()
        self.idle_bytes = 0

    # -- internals -----------------------------------------------------------------------------
    def _drop(self, entry: Entry) -> None:
        """The entry forgotten, its pair kept idle for reuse while the idle ones hold at most
        IDLE_BYTES, else deleted."""
        self.bytes -= entry.bytes
        pair = entry.textures
        if self.idle_bytes + pair.bytes <= IDLE_BYTES:
            self._idle.setdefault(pair.size, []).append(pair)
            self.idle_bytes += pair.bytes
        else:
            pair.release()

    def _pair(self, size: tuple[int, int]) -> SnapshotTextures:
        """An idle pair of textures of `size` (texels), or a new one."""
        idle = self._idle.get(size)
        if idle:
            pair = idle.pop()
            self.idle_bytes -= pair.bytes
            return pair
        ctx = self.gl.ctx
        height = ctx.texture(size, 1, dtype="f4")
        normal = ctx.texture(size, 4, dtype="f1")
        for texture in (height, normal):
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return SnapshotTextures(size, height, normal)

    def _blit(self, copies: list[Copy]) -> None:
        """glBlitFramebuffer, NEAREST, of each copy's rectangle (same format on both sides:
        exact); the scissor test is off (`preserved` starts from `neutral`). A snapshot texture
        is read or written through one of the log's two framebuffers, attached for the copy
        (making a framebuffer per snapshot cost llvmpipe as much as its two textures). A map's
        framebuffer (moderngl's) is bound first and again afterwards: moderngl applies its
        colour mask (ours write all) and keeps it as the one bound. A side is bound (and a
        snapshot texture attached) only where it differs from the copy before's."""
        gl = gl_library()
        maps = next(side for copy in copies for side in (copy[0], copy[2]) if _is_fbo(side))
        maps.use()
        read, draw = self._framebuffers()
        bound: list[Side | None] = [None, None]  # the read side and the draw side
        for source, (sx, sy), target, (tx, ty), w, h in copies:
            if source is not bound[0]:
                _bind(gl, _READ_FRAMEBUFFER, source, read)
                bound[0] = source
            if target is not bound[1]:
                _bind(gl, _DRAW_FRAMEBUFFER, target, draw)
                bound[1] = target
            gl.glBlitFramebuffer(
                sx, sy, sx + w, sy + h, tx, ty, tx + w, ty + h, _COLOR_BUFFER_BIT, _NEAREST
            )
        gl.glBindFramebuffer(_FRAMEBUFFER, maps.glo)

    def _framebuffers(self) -> tuple[int, int]:
        """The log's two framebuffers (GL names) that snapshot textures are attached to."""
        if self._fbos is None:
            names = (ctypes.c_uint * 2)()
            gl_library().glGenFramebuffers(2, names)
            self._fbos = (names[0], names[1])
        return self._fbos


def _snapshot_copies(entry: Entry) -> list[Copy]:
    """The copies that record `entry`: each snapshot's rectangle of its maps into its place in
    the entry's pair of textures, every height, then every normal, so that the copies into one
    texture run one after the other (`UndoLog._blit` attaches it once)."""
    pair = entry.textures
    heights: list[Copy] = [
        (snap.maps.height_fbo, snap.rect[:2], pair.height, snap.at, *snap.rect[2:])
        for snap in entry
    ]
    normals: list[Copy] = [
        (snap.maps.normal_fbo, snap.rect[:2], pair.normal, snap.at, *snap.rect[2:])
        for snap in entry
    ]
    return heights + normals


def _kib(count: int) -> str:
    """A byte count for a message, in KiB (MiB from 1 MiB)."""
    return f"{count / (1 << 20):.1f} MiB" if count >= 1 << 20 else f"{count / 1024:.1f} KiB"


def _is_fbo(side: Side) -> bool:
    return isinstance(side, moderngl.Framebuffer)


def _bind(gl: ctypes.CDLL, target: int, side: Side, own: int) -> None:
    """Bind a map's framebuffer to `target`, or the log's framebuffer `own` with a snapshot
    texture as its colour attachment."""
    if _is_fbo(side):
        gl.glBindFramebuffer(target, side.glo)
        return
    gl.glBindFramebuffer(target, own)
    gl.glFramebufferTexture2D(target, _COLOR_ATTACHMENT0, _TEXTURE_2D, side.glo, 0)


def restore_pristine(
    gl: GLContext,
    gpu_mesh: GpuMesh,
    maps: SurfaceMaps,
    heights: NDArray[np.float32] | None = None,
) -> None:
    """A body's maps as they started: the height map cleared to 0 on the GPU, or `heights` (the
    start map, float32 [v, u] metres, as it was first written) uploaded, and every normal
    rebuilt (a pristine one: every normal flat, `surface.flatten`). The host's GL state is left
    as it was."""
    with preserved(gl.ctx):
        if heights is None:
            flatten(maps)
        else:
            maps.height.write(np.ascontiguousarray(heights, dtype=np.float32).tobytes())
            rebuild_all_normals(gl, gpu_mesh, maps)
        wait_for_writes(gl)


def wait_for_writes(gl: GLContext) -> None:
    """glFinish after an undo or a repair (a user's action, not once a frame; no readback).
    Mesa 22.3's llvmpipe let a read of a map just after them return the map as it was before
    them (in 2-5 of 240 undos, by draw or by blit, and after repairs), as if it lost track of
    writes still in flight; with glFinish none did in 480."""
    gl.ctx.finish()
