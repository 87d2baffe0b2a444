"""Scratches in the sandbox: the physics' sliding pairs (physics/world.py's `Slide`: normal force
times slip, each step) wear Archard's volume V = K F s / H from each body, with its own K and H,
times the scene's `wear_scale`; the volume builds up per (worn body, tool body) along the tool's
path over the worn body, and is carved as a groove segment (app/scratch.py's swept tool: a
sphere swept along the segment is a capsule, pressed square-on by the depth whose cross-section
times the segment's length is the volume) once the path is SEGMENT_LENGTH long, or when the
pair stops sliding. A segment shallower than VISIBLE_DEPTH is dropped with its volume: it would
not show at a sandbox's texels. Pure rolling slips nothing (the physics reports no slide), so it
wears nothing; a slide that stops ends its groove.

Tools, each the other body's local shape at the contact: a sphere (a ball skidding; swept, a
built-in capsule, kept per size); a box (a crate sliding; swept, the convex hull of its corners
at both ends of the segment, mesh/hull.py, made per segment, its depth the one whose
cross-section across the path, the box's corners projected along it, times the segment is the
volume); a capsule or a cylinder (its cap, side or rim: the support points of directions fanned
across the path about the contact's, `_profile`) and a loaded mesh (its triangles near the
contact, `_patch`): each swept as a prism, its cross-section across the path (at most
RING_POINTS corners) run from the tool's print at the segment's start to its print at the end.
A plate, static, is not a tool here: what slides over it keeps the same face on it (a crate) or
turns it slowly (a skidding ball), so that face's wear piles up pass after pass, which one
MIN-blended groove per segment cannot hold (`dentdemo scratch --tool plate` drags one over a
target). Worn bodies: any dentable body but the ground plane."""

from __future__ import annotations

import math
import warnings
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, replace
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
from dentdemo.model.shapes import Box, Capsule, Cylinder, MeshFile, Plane, Shape, Sphere, support

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
#: Capsules a sandbox keeps on the GPU (`GrooveTools`): one per ball radius and rounded length;
#: a sandbox of balls of many sizes makes more, the least recently used are made again.
CAPSULES_KEPT = 64
#: The swept tool's map side at most, texels (only its pitch matters: the carve's pixels grow
#: to one of its texels).
TOOL_MAP_MAX = 1024
#: Corners a curved tool's or a mesh patch's cross-section keeps: its prism's 16 points at both
#: ends are what a hit log's groove record holds (a box's 8 corners twice). With the profile's
#: corners spread over twice the groove's depth, the circle between two of them sags about 1/18
#: of the depth.
RING_POINTS = 8
#: Directions fanned across the path to find a curved tool's profile, before RING_POINTS of the
#: support points are kept.
FAN = 33
#: Half-angles of the fan tried in turn, radians: the first whose profile stands at least twice
#: the groove's depth above the tool's lowest point is kept (a flat face: the widest).
CONES = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.4, 0.8, 1.5)
#: How high a curved profile's kept corners stand, times the groove's depth: the cone is fitted
#: to it (a lower profile's top chord would cut the groove; a higher one spends corners).
RISE = 1.3
#: A mesh tool's patch: its triangles within this distance of the contact, m (each triangle's
#: bounding sphere about its centroid).
PATCH_RADIUS = 0.02


@dataclass
class _Track:
    """The path of a tool over a worn body since its groove's last segment: the contact point at
    its start and now, and the contact's outward normal now, all in the worn body's local frame
    (metres), the volume worn meanwhile, m^3, and whether it is the slide's first segment (a
    prism's groove then holds the tool's print at the start too)."""

    start: NDArray[np.float64]
    end: NDArray[np.float64]
    point: NDArray[np.float64]
    normal: NDArray[np.float64]
    volume: float = 0.0
    fresh: bool = True


@dataclass(frozen=True)
class Groove:
    """One segment to carve: `worn` pressed by `tool` swept along `track`: a sphere of `radius`,
    or the hull of `points` (16, 3: a box's corners, or a prism's cross-section, at both ends of
    the segment), in the worn body's frame, touching the contact's plane (first touch)."""

    worn: str
    tool: str
    radius: float
    track: _Track
    depth: float
    points: NDArray[np.float64] | None = None
    #: The worn body's coat, m thick, and how much faster its material wears than the coat.
    coat: tuple[float, float] = (0.0, 1.0)


@dataclass(frozen=True)
class GrooveTool:
    """The solid a groove segment is pressed with, as a hit log records it: a sphere of
    `radius` swept along `length` (a capsule), or, with `points`, the hull of a box's corners
    at both ends of the segment or a prism's (16 x 3 float64, the worn body's frame, metres)."""

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
    """Swept tools on the GPU: capsules made once per radius and rounded length and kept (the
    CAPSULES_KEPT used last), box hulls made per batch and released at the next (`next_batch`).
    The carve and a hit log's replay share them.

    A groove's press dents only the worn body (no tool depth), so a tool's heights stay 0 and
    the carve reads nothing else of its maps but their texel size: the capsules whose maps have
    one side share one set of textures (made with the first of them; its chart mask is no other
    capsule's, and nothing reads a tool's mask), each with its own texel size."""

    def __init__(self, gl: GLContext) -> None:
        self.gl = gl
        #: Capsules by (radius, rounded length), least recently used first, each with its maps
        #: by the texel size asked for (views of the shared ones).
        self._capsules: OrderedDict[
            tuple[float, float], tuple[GpuMesh, dict[float, SurfaceMaps]]
        ] = OrderedDict()
        #: Those `body` gave since the last `next_batch`: a batch's presses hold them.
        self._in_use: set[tuple[float, float]] = set()
        #: The shared flat maps, by side.
        self._flat: dict[int, SurfaceMaps] = {}
        #: The swept boxes of the last batch (one hull each), released at the next.
        self._hulls: list[tuple[GpuMesh, SurfaceMaps]] = []

    def next_batch(self) -> None:
        """The swept boxes of the batch before are released: it has been carved."""
        for gpu, maps in self._hulls:
            maps.release()
            gpu.release()
        self._hulls = []
        self._in_use.clear()

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
        `texel` (a power-of-two map side, up to TOOL_MAP_MAX)."""
        key = (radius, length)
        held = self._capsules.get(key)
        self._in_use.add(key)
        if held is None:
            held = (GpuMesh(self.gl, shape_mesh(Capsule(radius, length), Tessellation())), {})
            self._capsules[key] = held
            self._forget_unused()
        else:
            self._capsules.move_to_end(key)
        gpu, views = held
        maps = views.get(texel)
        if maps is None:
            mesh = gpu.mesh
            side = _power_of_two(map_size_for(mesh, 1.0 / texel, cap=TOOL_MAP_MAX))
            flat = self._flat.get(side)
            if flat is None:
                flat = self._flat[side] = create_maps(self.gl, gpu, side, 0.0)
            su, sv = mesh.uv_scale()
            maps = views[texel] = replace(flat, texel_metres=(su / side, sv / side))
        return gpu, maps

    def _forget_unused(self) -> None:
        """The capsules used least recently, beyond CAPSULES_KEPT, released (not those of the
        batch being made)."""
        for key in list(self._capsules):
            if len(self._capsules) <= CAPSULES_KEPT:
                break
            if key not in self._in_use:
                self._capsules.pop(key)[0].release()

    def release(self) -> None:
        self.next_batch()
        for gpu, _ in self._capsules.values():
            gpu.release()
        for maps in self._flat.values():
            maps.release()
        self._capsules.clear()
        self._flat.clear()


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
            and isinstance(other.spec.shape, Sphere | Box | Capsule | Cylinder | MeshFile)
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
        # The worn body's surface (a built-in solid's tangent plane with the contact's normal; a
        # mesh's, the tool's lowest point lifted by the contact's penetration: first touch), and
        # the path's point on it: a sphere's contact; a box's centre, since
        # its deepest contact jumps between its corners.
        shape = sim.bodies[tool].spec.shape
        centre = (inverse @ sim.model(tool)[:, 3])[:3]
        if isinstance(shape, Sphere):
            lowest = float(centre @ normal) - shape.radius
        else:  # its centre: the deepest contact of a box, a lying capsule, a mesh jumps
            lowest = float((_surface(sim, worn, tool, normal) @ normal).min())
            point = centre
        surface = lowest + slide.depth
        worn_shape = sim.bodies[worn].spec.shape
        if not isinstance(worn_shape, MeshFile):  # convex: its tangent plane, free of ODE's jitter
            surface = float(support(worn_shape, normal) @ normal)
        point = point + (surface - float(point @ normal)) * normal
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
            self.tracks[(worn, tool)] = _Track(point, point, point, normal, fresh=False)

    def _close(self, sim: Simulation, key: tuple[str, str], track: _Track) -> None:
        """The segment of `track` into `pending` if it is long and deep enough."""
        tool = sim.bodies.get(key[1])
        length = _length(track)
        if tool is None or length < LENGTH_STEP or track.volume <= 0:
            return
        shape = tool.spec.shape
        area = track.volume / length
        material = sim.bodies[key[0]].spec.material
        coat = (material.appearance.coat_thickness, material.coat_wear_ratio())
        if isinstance(shape, Sphere):
            depth = _sphere_depth(shape.radius, area, coat)
            groove = Groove(key[0], key[1], shape.radius, track, depth, coat=coat)
        elif isinstance(shape, Box):
            corners = _corners(sim, key[0], key[1], shape)
            depth = _section_depth(_section(corners, track), area, coat)
            points = _swept_box_points(corners, track)
            groove = Groove(key[0], key[1], 0.0, track, depth, points, coat)
        else:
            swept = _prism(sim, key[0], key[1], track, area, coat)
            if swept is None:
                return
            depth, points = swept
            groove = Groove(key[0], key[1], 0.0, track, depth, points, coat)
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
        if groove.points is not None:
            return Carved(
                groove.worn, GrooveTool(points=groove.points), model, model, contact, groove.depth
            )
        along = end - start
        length = float(np.linalg.norm(along))
        direction = along / length
        rounded = max(LENGTH_STEP, round(length / LENGTH_STEP) * LENGTH_STEP)
        depth = _sphere_depth(r, track.volume / rounded, groove.coat)
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
                    "fresh": t.fresh,
                }
                for (worn, tool), t in self.tracks.items()
            ],
            "worn": dict(self.worn),
            "carved": self.carved,
        }

    def restore(self, saved: SavedWear) -> None:
        """Go on from `saved` (pending grooves are carved in the step that makes them: none)."""
        self.clear()
        for key, (start, end, point, normal, volume, fresh) in saved.tracks:
            self.tracks[key] = _Track(
                start.copy(), end.copy(), point.copy(), normal.copy(), volume, fresh
            )
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


def _swept_box_points(corners: NDArray[np.float64], track: _Track) -> NDArray[np.float64]:
    """The corners of a box at both ends of the segment (the hull of them is the box swept
    along it), in the worn body's frame, touching the contact's plane (first touch)."""
    return _touching(np.vstack([corners - _shift(track), corners]), track)


def _shift(track: _Track) -> NDArray[np.float64]:
    """The segment's motion in the contact's plane, m (worn body's frame)."""
    along = track.end - track.start
    return along - (along @ track.normal) * track.normal


def _touching(points: NDArray[np.float64], track: _Track) -> NDArray[np.float64]:
    """`points` moved along the contact's normal until the lowest touches its plane."""
    n = track.normal
    return points - n * float(((points - track.point) @ n).min())


def _surface(sim: Simulation, worn: str, tool: str, normal: NDArray[np.float64]) -> NDArray:
    """Points of the tool's surface (the worn body's frame, m) that include its lowest along
    -`normal`: a box's corners, a capsule's or a cylinder's support point, a mesh's vertices."""
    shape = sim.bodies[tool].spec.shape
    if isinstance(shape, Box):
        return _corners(sim, worn, tool, shape)
    relative = np.linalg.inv(sim.model(worn)) @ sim.model(tool)
    if isinstance(shape, MeshFile):
        local = sim.bodies[tool].mesh.positions.astype(np.float64)
        return local @ relative[:3, :3].T + relative[:3, 3]
    down = relative[:3, :3].T @ -normal
    return (relative[:3, :3] @ support(shape, down) + relative[:3, 3])[None, :]


def _sphere_depth(radius: float, area: float, coat: tuple[float, float]) -> float:
    """A sphere's groove depth for the cross-section `area` its material alone would lose, m:
    through a coat of its own law, `wear.coated_depth` (docs/carve.md, "Grooves through a
    coat")."""
    if coat[0] <= 0.0 or coat[1] == 1.0:
        return wear.sphere_groove_depth(radius, area)
    return wear.coated_depth(lambda d: wear.segment_area(radius, d), area, *coat)


def _section_depth(
    section: list[tuple[float, float]], area: float, coat: tuple[float, float]
) -> float:
    """A convex cross-section's groove depth, as `_sphere_depth`, m."""
    if coat[0] <= 0.0 or coat[1] == 1.0:
        return wear.section_depth(section, area)
    return wear.coated_depth(lambda d: wear.section_area_beyond(section, d), area, *coat)


def _prism(
    sim: Simulation,
    worn: str,
    tool: str,
    track: _Track,
    area: float,
    coat: tuple[float, float],
) -> tuple[float, NDArray[np.float64]] | None:
    """A capsule's, a cylinder's or a mesh patch's groove segment: its depth (the cross-section
    `area`, m^2) and the prism's 16 points (the worn body's frame, touching the contact's plane):
    the cross-section across the path at the tool's print's front at the segment's start (what
    it sweeps anew: the surface behind its front was cut by the segment before; a slide's first
    segment from the print's back) and at its front at the end. None where the tool shows no
    cross-section (a knife's edge along the path)."""
    n = track.normal
    shift = _shift(track)
    length = float(np.linalg.norm(shift))
    along = shift / length
    across = np.cross(n, along)
    relative = np.linalg.inv(sim.model(worn)) @ sim.model(tool)
    shape = sim.bodies[tool].spec.shape
    if isinstance(shape, MeshFile):
        found = _patch(sim.bodies[tool].mesh, relative, track, across, along)
    else:
        found = _profile(
            shape, relative, lambda ring: _section_depth(ring, area, coat), n, across, along
        )
    if found is None:
        return None
    ring, lowest, (back, front) = found
    depth = _section_depth(ring, area, coat)
    ends = [((back if track.fresh else front) - length, ring), (front, ring)]
    points = np.array(
        [x * across + (lowest + y) * n + s * along for s, r in ends for x, y in r], dtype=float
    )
    # 16 points: a short ring's repeated (a hull ignores repeats).
    points = np.vstack([points, np.repeat(points[-1:], 2 * RING_POINTS - len(points), axis=0)])
    return depth, _touching(points, track)


def _ring(flat: NDArray[np.float64], lift: float) -> tuple[list[tuple[float, float]], float] | None:
    """The convex cross-section (across, height above the lowest) of points seen along the path,
    at most RING_POINTS corners, and how high its lowest top corner stands (0 for a flat face,
    which is given walls `lift` high), heights from the kept corners' lowest."""
    flat = flat.copy()
    flat[:, 1] -= flat[:, 1].min()
    width = float(np.ptp(flat[:, 0]))
    if width <= 1e-12:
        return None
    rise = min(float(flat[np.argmin(flat[:, 0]), 1]), float(flat[np.argmax(flat[:, 0]), 1]))
    if float(flat[:, 1].max()) <= 1e-9 * width:  # a flat face: its edges' walls
        rise = 0.0
        walls = flat[[np.argmin(flat[:, 0]), np.argmax(flat[:, 0])]] + np.array([0.0, lift])
        flat = np.vstack([flat, walls])
    ring = [(float(flat[i, 0]), float(flat[i, 1])) for i in convex_ring(flat, 1e-12 * width)]
    kept = wear.simplify_ring(ring, RING_POINTS)
    # Its lowest corner at 0 (the lowest point may have gone: the cut then starts at the chord).
    floor = min(y for _, y in kept)
    return [(x, y - floor) for x, y in kept], rise - floor


def _profile(
    shape: Shape,
    relative: NDArray[np.float64],
    depth_of: Callable[[list[tuple[float, float]]], float],
    n: NDArray[np.float64],
    across: NDArray[np.float64],
    along: NDArray[np.float64],
) -> tuple[list[tuple[float, float]], float, tuple[float, float]] | None:
    """A built-in tool's cross-section across the path: the support points of FAN directions
    fanned across it about -n, in the cone whose profile stands RISE times the groove's depth
    (`depth_of` a cross-section) above the lowest point; with the height of that point along n
    and the print's extent along the path (the support points of the cone's directions fore and
    aft), m."""
    rotation, centre = relative[:3, :3], relative[:3, 3]

    def points(directions: NDArray[np.float64]) -> NDArray[np.float64]:
        local = directions @ rotation  # each direction in the tool's frame
        return np.array([rotation @ support(shape, d) for d in local]) + centre

    def at(cone: float) -> tuple[tuple[list[tuple[float, float]], float] | None, tuple]:
        angles = np.linspace(-cone, cone, FAN)
        fan = points(np.outer(np.cos(angles), -n) + np.outer(np.sin(angles), across))
        ring = _ring(np.stack([fan @ across, fan @ n], axis=1), shape.bounding_radius())
        ends = points(np.array([-n * math.cos(cone) + s * along * math.sin(cone) for s in (-1, 1)]))
        spread = np.vstack([fan, ends]) @ along
        return ring, (float((fan @ n).min()), (float(spread.min()), float(spread.max())))

    for cone in CONES:
        found, (lowest, extent) = at(cone)
        if found is None:
            continue
        corners, rise = found
        depth = depth_of(corners)
        if rise == 0.0 or depth * RISE <= rise or cone == CONES[-1]:
            break
    else:
        return None
    if rise > 0.0 and depth > 0.0:  # a curved profile rises as the cone squared: fit RISE x d
        for _ in range(2):
            cone = min(cone * math.sqrt(RISE * depth / rise), CONES[-1])
            found, (lowest, extent) = at(cone)
            if found is None:
                return None
            corners, rise = found
            depth = depth_of(corners)
    return corners, lowest, extent


def _patch(
    mesh: Mesh,
    relative: NDArray[np.float64],
    track: _Track,
    across: NDArray[np.float64],
    along: NDArray[np.float64],
) -> tuple[list[tuple[float, float]], float, tuple[float, float]] | None:
    """A mesh tool's nearest patch: the vertices of its triangles within PATCH_RADIUS of the
    contact (under the tool's centre, on its lowest level), their cross-section across the
    path, the height of the lowest along n and their extent along the path, m."""
    n = track.normal
    p = mesh.positions.astype(np.float64) @ relative[:3, :3].T + relative[:3, 3]
    heights = p @ n
    centre = relative[:3, 3]
    contact = centre - n * (float(centre @ n) - float(heights.min()))
    corners = p[mesh.indices.astype(np.int64)]  # (t, 3, 3)
    middle = corners.mean(axis=1)
    reach = np.linalg.norm(corners - middle[:, None], axis=2).max(axis=1)
    near = np.linalg.norm(middle - contact, axis=1) - reach <= PATCH_RADIUS
    if not near.any():
        return None
    patch = np.unique(corners[near].reshape(-1, 3), axis=0)
    ring = _ring(np.stack([patch @ across, patch @ n], axis=1), PATCH_RADIUS)
    if ring is None:
        return None
    spread = patch @ along
    return ring[0], float((patch @ n).min()), (float(spread.min()), float(spread.max()))


@dataclass(frozen=True)
class SavedWear:
    """A saved state's `wear`, read and checked (`read_wear`)."""

    #: ((worn, tool), (start, end, point, normal, volume, fresh)), local metres and m^3.
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
        fresh = t.boolean("fresh", True)
        t.finish()
        tracks.append((key, (*points, normal, volume, fresh)))
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
