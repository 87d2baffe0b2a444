"""Scratches in the sandbox: the physics' sliding pairs (physics/world.py's `Slide`: normal force
times slip, each step) wear Archard's volume V = K F s / H from each body, with its own K and H,
times the scene's `wear_scale`; the volume builds up per (worn body, tool body) along the tool's
path over the worn body, and is carved as a groove segment (app/scratch.py's swept tool: a
sphere swept along the segment is a capsule, pressed square-on by the depth whose cross-section
times the segment's length is the volume) once the path is SEGMENT_LENGTH long, or when the
pair stops sliding. A segment shallower than VISIBLE_DEPTH is dropped with its volume: it would
not show at a sandbox's texels. Pure rolling slips nothing (the physics reports no slide), so it
wears nothing; a slide that stops ends its groove.

Tools: a sphere (a ball skidding; swept, a built-in capsule, kept per size) and a box (a crate
sliding; swept, the convex hull of its corners at both ends of the segment, mesh/hull.py, made
per segment, its depth the one whose cross-section across the path, the box's corners projected
along it, times the segment is the volume). A mesh, capsule or cylinder tool wears nothing yet.
Worn bodies: any dentable body but the ground plane."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody, Press
from dentdemo.carve.surface import create_maps, map_size_for
from dentdemo.gl.context import GLContext
from dentdemo.gpu.maps import SurfaceMaps
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.mesh.hull import convex_ring, hull_mesh
from dentdemo.mesh.mesh import Mesh
from dentdemo.mesh.shapes import Tessellation, shape_mesh
from dentdemo.model import wear
from dentdemo.model.shapes import Box, Capsule, Plane, Sphere

if TYPE_CHECKING:
    from dentdemo.app.simulation import Simulation
    from dentdemo.model.validate import TableReader
    from dentdemo.physics.world import Slide

#: A groove segment is carved once the tool has travelled this far over the worn body, m.
SEGMENT_LENGTH = 0.03
#: Shallower segments are dropped, m: 10 um is about a thousandth of a sandbox's 1 cm ball's
#: radius; at 1 mm texels its groove (half-width sqrt(2 R d)) spans a few texels.
VISIBLE_DEPTH = 1e-5
#: Swept tools are made per length rounded to this, m, and kept (a capsule of the rounded
#: length centred on the segment, pressed to the depth that wears the segment's volume over it).
LENGTH_STEP = 5e-3
#: The swept tool's map side at most, texels (only its pitch matters: the carve's pixels grow
#: to one of its texels).
TOOL_MAP_MAX = 1024


@dataclass
class _Track:
    """The path of a tool over a worn body since its groove's last segment: the contact point at
    its start and now, and the contact's outward normal now, all in the worn body's local frame
    (metres), and the volume worn meanwhile, m^3."""

    start: NDArray[np.float64]
    end: NDArray[np.float64]
    point: NDArray[np.float64]
    normal: NDArray[np.float64]
    volume: float = 0.0


@dataclass(frozen=True)
class Groove:
    """One segment to carve: `worn` pressed by `tool` swept along `track`: a sphere of `radius`,
    or a box whose `corners` (8, 3) are in the worn body's frame at the segment's end."""

    worn: str
    tool: str
    radius: float
    track: _Track
    depth: float
    corners: NDArray[np.float64] | None = None


@dataclass(frozen=True)
class GrooveTool:
    """The solid a groove segment is pressed with, as a hit log records it: a sphere of
    `radius` swept along `length` (a capsule), or, with `points`, the hull of a box's corners
    at both ends of the segment (16 x 3 float64, the worn body's frame, metres)."""

    radius: float = 0.0
    length: float = 0.0
    points: NDArray[np.float64] | None = None


@dataclass(frozen=True)
class Carved:
    """A groove segment as carved: the worn body, its tool, the worn body's pose and the tool's
    (world from local), the contact and the depth (metres)."""

    worn: str
    tool: GrooveTool
    model: NDArray[np.float64]
    tool_model: NDArray[np.float64]
    contact: ContactFrame
    depth: float


class GrooveTools:
    """Swept tools on the GPU: capsules made once per size and kept, box hulls made per batch
    and released at the next (`next_batch`). The carve and a hit log's replay share them."""

    def __init__(self, gl: GLContext) -> None:
        self.gl = gl
        self._tools: dict[tuple[float, float, float], tuple[GpuMesh, SurfaceMaps]] = {}
        self._meshes: dict[tuple[float, float], Mesh] = {}
        #: The swept boxes of the last batch (one hull each), released at the next.
        self._hulls: list[tuple[GpuMesh, SurfaceMaps]] = []

    def next_batch(self) -> None:
        """The swept boxes of the batch before are released: it has been carved."""
        for gpu, maps in self._hulls:
            maps.release()
            gpu.release()
        self._hulls = []

    def body(self, tool: GrooveTool, worn: SurfaceMaps, model: NDArray[np.float64]) -> CarveBody:
        """`tool` on the GPU, posed `model`; its texels no coarser than `worn`'s."""
        texel = min(worn.texel_metres)
        if tool.points is None:
            gpu, maps = self._capsule(tool.radius, tool.length, texel)
            return CarveBody(gpu, maps, model)
        mesh = hull_mesh(tool.points, "swept box")
        gpu = GpuMesh(self.gl, mesh)
        with warnings.catch_warnings():  # capped on purpose: only its pitch matters
            warnings.simplefilter("ignore")
            texels = map_size_for(mesh, 1.0 / texel, cap=TOOL_MAP_MAX)
        hull = (gpu, create_maps(self.gl, gpu, _power_of_two(texels), 0.0))
        self._hulls.append(hull)
        return CarveBody(gpu, hull[1], model)

    def _capsule(self, radius: float, length: float, texel: float) -> tuple[GpuMesh, SurfaceMaps]:
        """The capsule swept by a sphere of `radius` along `length`, its texels no coarser than
        `texel` (a power-of-two map side, up to TOOL_MAP_MAX); made once per size."""
        mesh = self._meshes.get((radius, length))
        if mesh is None:
            mesh = self._meshes[(radius, length)] = shape_mesh(
                Capsule(radius, length), Tessellation()
            )
        side = _power_of_two(map_size_for(mesh, 1.0 / texel, cap=TOOL_MAP_MAX))
        key = (radius, length, float(side))
        held = self._tools.get(key)
        if held is None:
            gpu = GpuMesh(self.gl, mesh)
            held = (gpu, create_maps(self.gl, gpu, side, 0.0))
            self._tools[key] = held
        return held

    def release(self) -> None:
        self.next_batch()
        for gpu, maps in self._tools.values():
            maps.release()
            gpu.release()
        self._tools.clear()
        self._meshes.clear()


class WearTracker:
    """Per (worn body, tool body), the volume worn along the tool's path; grooves waiting for
    the next carve batch in `pending`."""

    def __init__(self, gl: GLContext, scale: float) -> None:
        self.gl = gl
        self.scale = scale
        self.tracks: dict[tuple[str, str], _Track] = {}
        self.pending: list[Groove] = []
        #: Volume worn per body so far (before VISIBLE_DEPTH drops any), m^3.
        self.worn: dict[str, float] = {}
        #: Groove segments handed to the carve so far.
        self.carved = 0
        self.tools = GrooveTools(gl)
        #: The last `take`'s segments, in its order (a hit log records them).
        self.taken: list[Carved] = []

    def observe(self, sim: Simulation, slides: dict[tuple[str, str], Slide]) -> None:
        """One physics step's slides: wear builds up along each path; a path long enough, or
        one whose slide stopped, becomes a groove segment in `pending`."""
        sliding = set()
        for slide in slides.values():
            for worn, tool, outward in (
                (slide.body_a, slide.body_b, slide.normal),
                (slide.body_b, slide.body_a, -slide.normal),
            ):
                if self._wears(sim, worn, tool):
                    sliding.add((worn, tool))
                    self._add(sim, worn, tool, slide, outward)
        for key in [k for k in self.tracks if k not in sliding]:
            self._close(sim, key, self.tracks.pop(key))

    def _wears(self, sim: Simulation, worn: str, tool: str) -> bool:
        body, other = sim.bodies.get(worn), sim.bodies.get(tool)
        return (
            body is not None
            and other is not None
            and body.spec.dentable
            and not isinstance(body.spec.shape, Plane)
            and body.spec.material.wear_coefficient > 0
            and isinstance(other.spec.shape, Sphere | Box)
        )

    def _add(
        self, sim: Simulation, worn: str, tool: str, slide: Slide, outward: NDArray[np.float64]
    ) -> None:
        material = sim.bodies[worn].spec.material
        volume = self.scale * material.wear_coefficient * slide.work / material.hardness
        self.worn[worn] = self.worn.get(worn, 0.0) + volume
        inverse = np.asarray(np.linalg.inv(sim.model(worn)), dtype=np.float64)
        # The contact point at the step's last sliding substep (before its motion): where the
        # slide was when it stopped, not where the tool rolled on to by the step's end.
        point = (inverse @ np.append(slide.point, 1.0))[:3]
        normal = inverse[:3, :3] @ outward
        normal /= np.linalg.norm(normal)
        # The worn body's surface (the tool's lowest point lifted by the contact's penetration:
        # first touch), and the path's point on it: a sphere's contact; a box's centre, since
        # its deepest contact jumps between its corners.
        shape = sim.bodies[tool].spec.shape
        centre = (inverse @ sim.model(tool)[:, 3])[:3]
        if isinstance(shape, Box):
            lowest = float((_corners(sim, worn, tool, shape) @ normal).min())
            point = centre
        else:
            lowest = float(centre @ normal) - shape.radius  # type: ignore[union-attr]
        point = point + (lowest + slide.depth - float(point @ normal)) * normal
        track = self.tracks.get((worn, tool))
        if track is None:  # the slide began during this step: its path from the step's start
            physics = sim.scene.physics
            before = physics.dt * (1.0 - 1.0 / physics.substeps)
            began = point - _relative_velocity(sim, worn, tool, inverse) * before
            track = _Track(began, point, point, normal, volume)
            self.tracks[(worn, tool)] = track
        else:
            track.end, track.point, track.normal = point, point, normal
            track.volume += volume
        if _length(track) >= SEGMENT_LENGTH:
            self._close(sim, (worn, tool), track)
            self.tracks[(worn, tool)] = _Track(point, point, point, normal)

    def _close(self, sim: Simulation, key: tuple[str, str], track: _Track) -> None:
        """The segment of `track` into `pending` if it is long and deep enough."""
        tool = sim.bodies.get(key[1])
        length = _length(track)
        if tool is None or length < LENGTH_STEP or track.volume <= 0:
            return
        shape = tool.spec.shape
        if isinstance(shape, Box):
            corners = _corners(sim, key[0], key[1], shape)
            depth = wear.section_depth(_section(corners, track), track.volume / length)
            groove = Groove(key[0], key[1], 0.0, track, depth, corners)
        else:
            radius = shape.radius  # type: ignore[union-attr]
            depth = wear.sphere_groove_depth(radius, track.volume / length)
            groove = Groove(key[0], key[1], radius, track, depth)
        if depth >= VISIBLE_DEPTH:
            self.pending.append(groove)

    def take(self, sim: Simulation) -> list[Press]:
        """The pending grooves as presses (their worn body posed as it is now), and none left;
        `taken` describes them. The swept boxes of the batch before are released."""
        self.tools.next_batch()
        self.taken = []
        for groove in self.pending:
            body = sim.bodies.get(groove.worn)
            if body is None:
                continue
            self.taken.append(self._carved(body.maps, sim.model(groove.worn), groove))
        self.pending = []
        self.carved += len(self.taken)
        return [press_of(sim, c, self.tools) for c in self.taken]

    def _carved(self, maps: SurfaceMaps, model: NDArray[np.float64], groove: Groove) -> Carved:
        track, r = groove.track, groove.radius
        n = track.normal
        # The path in the contact's plane, the swept sphere's axis R above it (first touch).
        start = track.start - ((track.start - track.point) @ n) * n
        end = track.end - ((track.end - track.point) @ n) * n
        mid = model @ np.append((start + end) / 2, 1.0)
        press_in = -(model[:3, :3] @ n)
        contact = ContactFrame(mid[:3], press_in / np.linalg.norm(press_in))
        if groove.corners is not None:
            points = _swept_box_points(groove, end - start)
            return Carved(
                groove.worn, GrooveTool(points=points), model, model, contact, groove.depth
            )
        along = end - start
        length = float(np.linalg.norm(along))
        direction = along / length
        rounded = max(LENGTH_STEP, round(length / LENGTH_STEP) * LENGTH_STEP)
        depth = wear.sphere_groove_depth(r, track.volume / rounded)
        local = np.eye(4)
        local[:3, :3] = np.column_stack([np.cross(n, direction), n, direction])
        local[:3, 3] = (start + end) / 2 + n * r
        return Carved(groove.worn, GrooveTool(r, rounded), model, model @ local, contact, depth)

    def saved(self) -> dict[str, object]:
        """The tracks (a slide under way), the volume worn per body and the segments carved, as
        a saved state's `wear` (floats as Python writes them back exactly)."""
        return {
            "tracks": [
                {
                    "worn": worn,
                    "tool": tool,
                    **{k: getattr(t, k).tolist() for k in ("start", "end", "point", "normal")},
                    "volume": t.volume,
                }
                for (worn, tool), t in self.tracks.items()
            ],
            "worn": dict(self.worn),
            "carved": self.carved,
        }

    def restore(self, saved: SavedWear) -> None:
        """Go on from `saved` (pending grooves are carved in the step that makes them: none)."""
        self.clear()
        for key, (start, end, point, normal, volume) in saved.tracks:
            self.tracks[key] = _Track(start.copy(), end.copy(), point.copy(), normal.copy(), volume)
        self.worn = dict(saved.worn)
        self.carved = saved.carved

    def forget(self, body_id: str) -> None:
        """A body is gone: its tracks and pending grooves with it."""
        self.tracks = {k: t for k, t in self.tracks.items() if body_id not in k}
        self.pending = [g for g in self.pending if body_id not in (g.worn, g.tool)]

    def clear(self) -> None:
        self.tracks.clear()
        self.pending = []
        self.worn.clear()

    def release(self) -> None:
        self.tools.release()


def press_of(sim: Simulation, carved: Carved, tools: GrooveTools) -> Press:
    """A groove segment as a press of its worn body (the carve, and a hit log's replay)."""
    body = sim.bodies[carved.worn]
    target = CarveBody(body.gpu_mesh, body.maps, carved.model)
    tool = tools.body(carved.tool, body.maps, carved.tool_model)
    return Press(target, tool, carved.contact, carved.depth)


def _swept_box_points(groove: Groove, shift: NDArray[np.float64]) -> NDArray[np.float64]:
    """The corners of a box at both ends of the segment (the hull of them is the box swept
    along it), in the worn body's frame, touching the contact's plane (first touch)."""
    assert groove.corners is not None
    track, n = groove.track, groove.track.normal
    points = np.vstack([groove.corners - shift, groove.corners])
    points -= n * float(((points - track.point) @ n).min())
    return points


@dataclass(frozen=True)
class SavedWear:
    """A saved state's `wear`, read and checked (`read_wear`)."""

    #: ((worn, tool), (start, end, point, normal, volume)), local metres and m^3.
    tracks: tuple[tuple[tuple[str, str], tuple], ...]
    worn: dict[str, float]
    carved: int


#: Bounds of a saved state's wear: tracks (one per touching pair), metres from a body's origin.
TRACKS_MAX = 100_000
REACH_M = 1e4


def read_wear(r: TableReader, bodies: set[str]) -> SavedWear:
    """A saved state's `wear` table, every value checked; `bodies`: the state's body ids."""
    tracks = []
    for i, entry in enumerate(r.items("tracks", TRACKS_MAX)):
        t = type(r)(r.source, f"{r.table_name}.tracks[{i}]", entry)
        key = (t.string("worn", choices=sorted(bodies)), t.string("tool", choices=sorted(bodies)))
        points = [
            np.array(t.vector(name, None, 3, REACH_M, "distance from the body's origin (m)"))
            for name in ("start", "end", "point")
        ]
        normal = np.array(t.vector("normal", None, 3, 1.0 + 1e-6, "length"))
        volume = t.number("volume", None, min_value=0.0, max_value=REACH_M)
        t.finish()
        tracks.append((key, (*points, normal, volume)))
    worn_table = r.table_at("worn")
    for body in worn_table.table:
        if body not in bodies:
            raise worn_table.fail(body, "names no body of the state")
    worn = {
        body: worn_table.number(body, None, min_value=0.0, max_value=REACH_M)
        for body in sorted(worn_table.table)
    }
    worn_table.finish()
    carved = r.integer("carved", min_value=0, max_value=2**53)
    r.finish()
    return SavedWear(tuple(tracks), worn, carved)


def _power_of_two(side: int) -> int:
    """The power of two at or above `side`, up to TOOL_MAP_MAX (a swept tool's map side)."""
    return min(1 << (side - 1).bit_length(), TOOL_MAP_MAX)


def _corners(sim: Simulation, worn: str, tool: str, box: Box) -> NDArray[np.float64]:
    """The box's corners in the worn body's frame, metres."""
    half = np.asarray(box.size) / 2.0
    local = np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    local[:, :3] *= half
    relative = np.linalg.inv(sim.model(worn)) @ sim.model(tool)
    return (local @ relative.T)[:, :3]


def _section(corners: NDArray[np.float64], track: _Track) -> list[tuple[float, float]]:
    """The swept box's cross-section across the path: its corners projected along the path onto
    (across, height above its lowest point), their convex hull counter-clockwise."""
    n = track.normal
    along = track.end - track.start
    along -= (along @ n) * n
    across = np.cross(n, along / max(float(np.linalg.norm(along)), 1e-30))
    flat = np.stack([corners @ across, corners @ n], axis=1)
    flat[:, 1] -= flat[:, 1].min()
    ring = convex_ring(flat, 1e-12)
    return [(float(flat[i, 0]), float(flat[i, 1])) for i in ring]


def _relative_velocity(
    sim: Simulation, worn: str, tool: str, inverse: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The tool's centre's velocity in the worn body's frame, m/s (local axes): the contact
    point's too, for a sphere sliding over a face."""
    worn_v, worn_w = sim.world.velocity(worn)
    tool_v, _ = sim.world.velocity(tool)
    offset = sim.model(tool)[:3, 3] - sim.model(worn)[:3, 3]
    return inverse[:3, :3] @ (tool_v - worn_v - np.cross(worn_w, offset))


def _length(track: _Track) -> float:
    """How far the contact moved in the worn body's tangent plane, m."""
    along = track.end - track.start
    across = float(along @ track.normal)
    return math.sqrt(max(float(along @ along) - across * across, 0.0))
