"""A deterministic scratch with no physics (the pin-on-disc test of the wear model): a tool dragged
at constant load along a straight path on a target's upper face, the groove Archard's law wears
carved as presses of the tool swept along the path, and the groove measured against the law.

The carve moves a tool only along its view direction (docs/carve.md, "What a press means"), so a
tool dragged along the surface is carved as square-on presses (along the face's inward normal)
of the *swept* tool: a sphere swept along a segment is a capsule (a built-in solid with its own
analytic surface), a box swept along its own z axis a longer box. Each segment's swept tool is
posed touching the surface and pressed by the groove's depth d, which Archard's volume fixes:
the groove's cross-section A(d) times the distance slid is V = K F s / H. The swept solid also
holds the tool's own print at either end (for a sphere two half caps, one cap's volume
pi d^2 (3R - d) / 3; for a box its flat print, x z d), which the prediction counts.

A long path is cut into equal segments, each short enough that its footprint fits one collision
camera at the target's texel pitch (`Carver.max_resolution` pixels): a camera's pixels otherwise
grow past a micron groove's width. Collinear capsules (and boxes) that share their end points
union to the one long solid, and the carve keeps the deeper height (MIN) where they overlap, so
the segments leave the same groove as one press of the whole path would.

Tools lie along the path (local z): a sphere, a capsule or a cylinder cuts its circle's segment
A(d) (swept, a longer capsule, carved as its smooth solid, or a longer cylinder, its facets fine
enough to sag FACET_SAG of the depth); a box or a plate (face down) its flat width, A(d) = w d
(swept, a longer box). Each adds its print at the ends: a capsule's A(d) l plus a sphere's cap, a
cylinder's A(d) l, a box's x z d, a plate's side^2 d.

On a sphere the path is an arc of a great circle, `distance` long on the surface, and each segment
a chord of it (a capsule, or a box face down, square-on to the surface at the chord's middle): the
chord sags below the arc by L^2 / (8 (R + r)) at its ends (a box: L^2 / (8 R)), so the segments
are kept short enough that the sag is at most SAG_FRACTION of the groove's depth, and each is
pressed a third of its sag deeper (the depth along a chord, d + sag/3 - x^2 / (2 (R + r)), then
averages d). The groove's cross-section is the
lens the tool's circle cuts from the ball's (`wear.lens_area`), its ends the two balls' overlap;
a box's, the ball's circular segment under the face's chord, clipped to the face's width
(`wear.strip_area`, closed form), its ends the ball's cap under the face."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dentdemo import outputs
from dentdemo.app.press import aim_point
from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody, Carver, Press
from dentdemo.carve.surface import create_maps
from dentdemo.errors import DentdemoError
from dentdemo.gl.context import GLContext
from dentdemo.gpu.maps import SurfaceMaps
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.mesh.primitives import sphere_texel_areas
from dentdemo.mesh.shapes import Tessellation, shape_mesh
from dentdemo.model import wear
from dentdemo.model.materials import Material
from dentdemo.model.shapes import Box, Capsule, Cylinder, Plate, Shape, Sphere, as_dict, support

#: Texels across the groove's half-width the automatic map size aims at: sampled at texel
#: centres, a groove of n texels a half-width integrates to within -1/(4 n^2) .. +1/(8 n^2) of
#: its volume (the worst phase of the texel lattice across it), 1.6 % at 4.
TEXELS_PER_HALF_WIDTH = 4
#: Largest and smallest automatic target map side, texels.
MAX_AUTO_MAP = 8192
MIN_AUTO_MAP = 256
#: Pixels a segment's footprint may take along the path, of the camera's `max_resolution`: the
#: rest is the camera's margin (two texels and a pixel each side) with room.
SEGMENT_PIXELS = 0.9
#: The most a segment's chord may sag below a sphere target's arc, a fraction of the groove's
#: depth: the groove's depth along the path stays within -2/3 .. +1/3 of it about d.
SAG_FRACTION = 0.1
#: A height below this counts as grooved, metres (float32 holds a pristine 0 exactly).
GROOVED = 0.0


@dataclass(frozen=True)
class Drag:
    """What the tool does: pressed with `load_n` newtons while it travels `distance_m` along
    `direction` (a unit vector in the target's face) from `start` (world, on the face), at
    `speed_m_s`; `slip` of the way it slides (1: dragged, 0: rolls without slip)."""

    load_n: float
    distance_m: float
    speed_m_s: float
    slip: float = 1.0

    @property
    def slide_m(self) -> float:
        return self.slip * self.distance_m


@dataclass(frozen=True)
class Groove:
    """The groove Archard's law asks for along a straight path (metres, m^2, m^3)."""

    #: The groove's volume along the path, A(d) * distance: K F s / H with the target's K and H
    #: (through a coat, the coat's part with the coat's and the metal's with the metal's).
    archard_volume: float
    #: Its cross-section A(d).
    area: float
    depth: float
    #: Half its width at the surface.
    half_width: float
    #: The tool's print at the two ends, which the swept tool adds to A(d) * distance.
    ends_volume: float
    #: The part of the cross-section within the coat, m^2 (all of it without a coat), and the
    #: coat's thickness, m (0: none).
    coat_area: float = 0.0
    coat: float = 0.0

    def predicted_volume(self, distance: float) -> float:
        return self.area * distance + self.ends_volume


def groove_for(
    tool: Shape, target: Material, drag: Drag, target_shape: Shape | None = None
) -> Groove:
    """The groove `tool` wears into a `target` body: V = K F s / H with the target's own K and H,
    spread over the path so that A(d) * distance = V (on a sphere target, A the lens a sphere
    tool's circle cuts from the ball's; the ball's curvature across the path narrows it). A
    coat with a wear law of its own takes its part of the work at its own rate
    (`wear.coated_depth`)."""
    volume = wear.archard_volume(
        target.wear_coefficient, drag.load_n, drag.slide_m, target.hardness
    )
    area = volume / drag.distance_m
    coat = target.appearance.coat_thickness
    ratio = target.coat_wear_ratio()

    def groove(
        area_at: Callable[[float], float],
        plain: Callable[[float], float],
        half: Callable[[float], float],
        ends: Callable[[float], float],
    ) -> Groove:
        depth = (
            plain(area)
            if coat <= 0 or ratio == 1.0
            else wear.coated_depth(area_at, area, coat, ratio)
        )
        cut = area_at(depth)
        within = cut - area_at(max(depth - coat, 0.0)) if coat > 0 else cut
        return Groove(cut * drag.distance_m, cut, depth, half(depth), ends(depth), within, coat)

    match tool, target_shape:
        case Sphere(radius=r), Sphere(radius=big):
            return groove(
                lambda d: wear.lens_area(big, r, d),
                lambda a: wear.lens_groove_depth(big, r, a),
                lambda d: _lens_half_width(big, r, d),
                lambda d: wear.ball_lens_volume(big, r, d),
            )
        case Box(size=(x, _, z)), Sphere(radius=big):
            return groove(
                lambda d: wear.strip_area(big, x, d),
                lambda a: wear.strip_groove_depth(big, x, a),
                lambda d: min(x / 2, wear.segment_half_width(big, d)),
                lambda d: flat_print_on_ball(big, x, z, d),
            )
        case _, Sphere():
            raise DentdemoError("--tool: a sphere target is scratched with a sphere or a box tool")
    match tool:
        case Sphere(radius=r) | Capsule(radius=r) | Cylinder(radius=r):
            capped = not isinstance(tool, Cylinder)
            return groove(
                lambda d: wear.segment_area(r, d),
                lambda a: wear.sphere_groove_depth(r, a),
                lambda d: wear.segment_half_width(r, d),
                lambda d: (
                    wear.segment_area(r, d) * _extent(tool)
                    + (wear.cap_volume(r, d) if capped else 0.0)
                ),
            )
        case Box(size=(width, _, _)) | Plate(side=width):
            return groove(
                lambda d: width * max(d, 0.0),
                lambda a: wear.box_groove_depth(width, a),
                lambda d: width / 2,
                lambda d: width * _extent(tool) * d,
            )
    raise DentdemoError(f"--tool: a scratch takes no {type(tool).__name__} tool")


#: Samples a side of the midpoint rule over a flat face's print on a ball (where the face is
#: narrower than the print).
PRINT_SAMPLES = 400


def flat_print_on_ball(radius: float, width: float, length: float, depth: float) -> float:
    """Volume a flat face `width` x `length` pressed `depth` into a ball of `radius` cuts, m^3:
    the ball's cap, pi d^2 (3R - d) / 3, where the face covers the cap's disc (radius
    sqrt(2 R d - d^2)); else the cap over the face's rectangle by the midpoint rule."""
    a = wear.segment_half_width(radius, depth)
    if width / 2 >= a and length / 2 >= a:
        return wear.cap_volume(radius, depth)
    hx, hz = min(width / 2, a), min(length / 2, a)
    x = ((np.arange(PRINT_SAMPLES) + 0.5) / PRINT_SAMPLES * 2 - 1) * hx
    z = ((np.arange(PRINT_SAMPLES) + 0.5) / PRINT_SAMPLES * 2 - 1) * hz
    rho2 = x[None, :] ** 2 + z[:, None] ** 2
    cut = np.sqrt(np.maximum(radius * radius - rho2, 0.0)) - (radius - depth)
    return float(np.maximum(cut, 0.0).sum() * (2 * hx / PRINT_SAMPLES) * (2 * hz / PRINT_SAMPLES))


def _extent(tool: Shape) -> float:
    """How long the tool lies along the path beyond a point, m (its print's straight part)."""
    match tool:
        case Capsule(length=length) | Cylinder(length=length):
            return length
        case Box(size=(_, _, z)):
            return z
        case Plate(side=side):
            return side
    return 0.0


def _lens_half_width(big: float, r: float, depth: float) -> float:
    """Half the width at the surface of a sphere's groove `depth` deep in a ball of radius `big`,
    m: the distance of the two circles' crossing from the line through their centres."""
    if depth <= 0:
        return 0.0
    c = big + r - depth
    along = (c * c + r * r - big * big) / (2.0 * c)
    return math.sqrt(max(r * r - along * along, 0.0))


def swept(tool: Shape, length: float) -> Shape:
    """`tool` swept `length` metres along its local z: a sphere a capsule, a capsule or a
    cylinder a longer one, a box a longer box, a plate (face down) a box."""
    match tool:
        case Sphere(radius=r):
            return Capsule(r, length)
        case Capsule(radius=r, length=l):
            return Capsule(r, l + length)
        case Cylinder(radius=r, length=l):
            return Cylinder(r, l + length)
        case Box(size=(x, y, z)):
            return Box((x, y, z + length))
        case Plate(side=side, thickness=t):
            return Box((side, t, side + length))
    raise DentdemoError(f"--tool: a scratch takes no {type(tool).__name__} tool")


@dataclass
class ScratchSetup:
    """The target at the origin with its maps, the path on its upper face, the groove and the
    swept tool's segments (each a CarveBody posed touching the face, sharing one mesh and map)."""

    target: CarveBody
    target_shape: Shape
    tool_shape: Shape
    start: NDArray[np.float64]
    direction: NDArray[np.float64]
    normal: NDArray[np.float64]
    groove: Groove
    drag: Drag
    segments: list[CarveBody]
    segment_length: float
    #: How far each segment is pressed, m: the groove's depth, plus a third of a chord's sag on
    #: a sphere.
    press_depth: float
    #: Each segment's swept length and press depth, m (across a box's edge the pivot's chords
    #: differ from the faces' segments).
    pieces: list[tuple[float, float]]

    def release(self) -> None:
        """The GL objects of both bodies (segments of one length share one mesh and map)."""
        bodies = {id(b.gpu_mesh): b for b in [self.target, *self.segments]}
        for body in bodies.values():
            body.maps.release()
            body.gpu_mesh.release()


def auto_map_size(target: Shape, groove: Groove) -> int:
    """A target map side whose texels put TEXELS_PER_HALF_WIDTH across the groove's half-width,
    within [MIN_AUTO_MAP, MAX_AUTO_MAP] (a plate's side, a cube's three faces, span its map)."""
    if groove.half_width <= 0:
        return MIN_AUTO_MAP
    metres_per_uv = max(shape_mesh(target, Tessellation.press(2)).uv_scale())
    wanted = math.ceil(metres_per_uv * TEXELS_PER_HALF_WIDTH / groove.half_width)
    return int(min(max(wanted, MIN_AUTO_MAP), MAX_AUTO_MAP))


def target_for(
    kind: str, drag: Drag, groove: Groove, tool: Shape, radius: float | None = None
) -> Shape:
    """A plate, or a cube, whose upper face holds the whole groove with a margin of its own
    width each side (and, a box tool, its print); or a sphere of `radius` (default: the
    distance, so that the path is an arc of one radian)."""
    if kind == "sphere":
        return Sphere(radius if radius is not None else drag.distance_m)
    extent = _extent(tool)
    side = drag.distance_m + extent + 6.0 * max(groove.half_width, 1e-4)
    return Box((side, side, side)) if kind == "box" else Plate(side)


def _pose(rotation: NDArray[np.float64], centre: NDArray[np.float64]) -> NDArray[np.float64]:
    model = np.eye(4)
    model[:3, :3] = rotation
    model[:3, 3] = centre
    return model


def make_scratch(
    gl: GLContext,
    target_shape: Shape,
    tool: Shape,
    material: Material,
    drag: Drag,
    map_size: int,
    heading: float = 0.0,
    max_resolution: int = 1023,
    arc_middle: float = 0.0,
    over_edge: bool = False,
) -> ScratchSetup:
    """The target, and the path centred on the middle of its upper face along `heading` (radians
    from +x towards +z), cut into segments that each fit one collision camera. On a sphere the
    path is the great circle through its top along `heading`, its middle `arc_middle` radians along
    it from the top. `over_edge` (a cube and a sphere tool): the path's first half runs on the top
    face to the middle of its +x edge, the ball pivots about the edge, and the second half runs
    down the +x face (`_over_edge`)."""
    groove = groove_for(tool, material, drag, target_shape)
    target_gpu = GpuMesh(gl, shape_mesh(target_shape, Tessellation.press(2)))
    maps = create_maps(gl, target_gpu, map_size, material.max_dent_depth)
    target = CarveBody(target_gpu, maps)
    middle, normal = aim_point(target_shape, (0.0, 0.0))
    direction = np.array([math.cos(heading), 0.0, math.sin(heading)])
    start = middle - direction * drag.distance_m / 2
    texel = min(maps.texel_metres)
    extent = 2.0 * groove.half_width + _extent(tool)
    longest = SEGMENT_PIXELS * max_resolution * texel - extent
    if longest <= 0:
        raise DentdemoError(
            f"--map-size: the tool's print ({extent:g} m) does not fit one carve camera at "
            f"{texel:g} m a texel; use a coarser map"
        )
    poses: list[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]]
    pieces: list[tuple[float, float]] = []
    if over_edge:
        if not isinstance(target_shape, Box) or not isinstance(tool, Sphere):
            raise DentdemoError("over an edge: a cube target and a sphere tool")
        start, poses, pieces = _over_edge(target_shape, tool, groove, drag, longest, heading)
        length, sag = pieces[0][0], 0.0
    elif isinstance(target_shape, Sphere):  # a sphere or a box tool (groove_for)
        radius = target_shape.radius
        start, poses, length, sag = _arc(radius, tool, groove, drag, longest, heading, arc_middle)
    else:
        count = max(1, math.ceil(drag.distance_m / longest))
        length, sag = drag.distance_m / count, 0.0
        poses = [(start + direction * (i + 0.5) * length, normal, direction) for i in range(count)]
    pieces = pieces or [(length, groove.depth + sag / 3.0)] * len(poses)
    tools: dict[float, tuple[GpuMesh, SurfaceMaps]] = {}
    segments = []
    for (mid, up, along), (piece, _) in zip(poses, pieces, strict=True):
        solid = swept(tool, piece)
        if piece not in tools:
            tool_mesh = shape_mesh(solid, _tessellation(tool, groove.depth))
            tool_gpu = GpuMesh(gl, tool_mesh)
            # The tool's texels no coarser than the target's: the camera's pixels grow to one.
            su, sv = tool_mesh.uv_scale()
            tool_side = min(max(16, math.ceil(max(su, sv) / texel)), 8192)
            tools[piece] = (tool_gpu, create_maps(gl, tool_gpu, tool_side, 0.0))
        # Tool frame: local z along the path, local y along the surface's normal (outwards).
        rotation = np.column_stack([np.cross(up, along), up, along])
        lift = rotation @ support(solid, np.array([0.0, -1.0, 0.0]))
        segments.append(CarveBody(*tools[piece], _pose(rotation, mid - lift)))
    return ScratchSetup(
        target,
        target_shape,
        tool,
        start,
        direction,
        normal,
        groove,
        drag,
        segments,
        length,
        groove.depth + sag / 3.0,
        pieces,
    )


def _over_edge(
    box: Box,
    tool: Sphere,
    groove: Groove,
    drag: Drag,
    longest: float,
    heading: float,
) -> tuple[
    NDArray[np.float64],
    list[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]],
    list[tuple[float, float]],
]:
    """A path across a cube's +x edge at z = 0: half the distance on the top face along
    `heading`, ending at the edge; the ball pivoting about the edge (the chords of a quarter
    circle round it, each touching the edge at its middle: their ends stand r (1/cos - 1)
    farther out, SAG_FRACTION of the depth at most, and each is pressed a third of that
    deeper); half down the +x face, the heading's slant kept. Its start (world, on the top
    face), each segment's middle on the surface with the outward normal and its direction, and
    each one's swept length and press depth, m."""
    half = np.asarray(box.size) / 2
    edge = np.array([half[0], half[1], 0.0])
    c, s = math.cos(heading), math.sin(heading)
    faces = [  # (outward normal, direction) of the top part, then of the side part
        (np.array([0.0, 1.0, 0.0]), np.array([c, 0.0, s])),
        (np.array([1.0, 0.0, 0.0]), np.array([0.0, -c, s])),
    ]
    run = drag.distance_m / 2
    count = max(1, math.ceil(run / longest))
    length = run / count
    top_start = edge - faces[0][1] * run
    poses = [(top_start + faces[0][1] * (i + 0.5) * length, *faces[0]) for i in range(count)]
    r = tool.radius
    step = 2.0 * math.acos(1.0 / (1.0 + SAG_FRACTION * max(groove.depth, 1e-12) / r))
    chords = max(1, math.ceil(math.pi / 2 / step))
    step = math.pi / 2 / chords
    pivot = []
    for i in range(chords):
        angle = (i + 0.5) * step  # from +y towards +x about the edge
        up = np.array([math.sin(angle), math.cos(angle), 0.0])
        pivot.append((edge.copy(), up, np.array([math.cos(angle), -math.sin(angle), 0.0])))
    sag = r * (1.0 / math.cos(step / 2) - 1.0)
    side = [(edge + faces[1][1] * (i + 0.5) * length, *faces[1]) for i in range(count)]
    chord = 2.0 * r * math.tan(step / 2)
    pieces = [(length, groove.depth)] * count
    pieces += [(chord, groove.depth + sag / 3.0)] * chords + [(length, groove.depth)] * count
    return top_start, poses + pivot + side, pieces


#: A cylinder tool's facets sag at most this part of the groove's depth (a built-in cylinder is
#: carved as its facets; a capsule as its smooth solid), and its sides are cut in at most
#: CYLINDER_AROUND segments.
FACET_SAG = 0.01
CYLINDER_AROUND = 4096


def _tessellation(tool: Shape, depth: float) -> Tessellation:
    """The swept tool's tessellation: the press's, and a cylinder cut finely enough that the
    facet under the groove sags FACET_SAG of its depth at most, r (1 - cos(pi / n))."""
    press = Tessellation.press(2)
    if not isinstance(tool, Cylinder) or depth <= 0:
        return press
    angle = math.acos(max(1.0 - FACET_SAG * depth / tool.radius, -1.0))
    around = min(max(press.around, 8 * math.ceil(math.pi / angle / 8)), CYLINDER_AROUND)
    return Tessellation(press.sphere, around, press.rings)


def _arc(
    radius: float,
    tool: Shape,
    groove: Groove,
    drag: Drag,
    longest: float,
    heading: float,
    middle: float,
) -> tuple[
    NDArray[np.float64],
    list[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]],
    float,
    float,
]:
    """A sphere's path: its start (world, on the surface), each chord's middle on the surface
    with the outward normal and the chord's direction there, the chord's length and its sag
    (how much farther from the centre its ends lie than its middle), m. Equal arcs, at most
    `longest` on the surface each (one camera) and short enough that the sag is at most
    SAG_FRACTION of the groove's depth."""
    # The swept sphere's axis, or the box's face, touching at a chord's middle.
    axis = radius + (tool.radius if isinstance(tool, Sphere) else 0.0)
    tangent = math.sqrt(8.0 * axis * SAG_FRACTION * max(groove.depth, 1e-12)) * radius / axis
    count = max(1, math.ceil(drag.distance_m / min(longest, tangent)))
    step = drag.distance_m / radius / count  # radians
    top = np.array([0.0, 1.0, 0.0])
    way = np.array([math.cos(heading), 0.0, math.sin(heading)])

    def at(angle: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return math.cos(angle) * top + math.sin(angle) * way, -math.sin(angle) * top + math.cos(
            angle
        ) * way

    first = middle - drag.distance_m / radius / 2
    poses = []
    for i in range(count):
        up, along = at(first + (i + 0.5) * step)
        poses.append((radius * up, up, along))
    sag = axis * (1.0 / math.cos(step / 2) - 1.0)
    return radius * at(first)[0], poses, 2.0 * axis * math.sin(step / 2), sag


def carve_groove(gl: GLContext, setup: ScratchSetup, carver: Carver | None = None) -> int:
    """Press every segment's swept tool by the groove's depth, in one batch (with `carver`, else
    one of its own); how many carved. A groove of depth 0 (nothing slid, or a material that does
    not wear) carves nothing."""
    if setup.groove.depth <= 0:
        return 0
    presses = []
    for body, (length, depth) in zip(setup.segments, setup.pieces, strict=True):
        point = body.centre() + body.model[:3, :3] @ support(
            swept(setup.tool_shape, length), np.array([0.0, -1.0, 0.0])
        )
        contact = ContactFrame(point, -body.model[:3, 1])  # square-on: its local -y
        presses.append(Press(setup.target, body, contact, depth, 0.0))
    own = carver or Carver(gl)
    try:
        jobs = own.carve_many(presses)
    finally:
        if carver is None:
            own.release()
    if not jobs:
        raise DentdemoError("the scratch's path misses the target: nothing was carved")
    return len(jobs)


def measure(height: NDArray[np.float32], setup: ScratchSetup) -> dict:
    """The groove as the map holds it: its volume (-height summed over the texels times a
    texel's area) and, over the path's straight part (its ends' prints left out), its depth
    along the path and its cross-section against the tool's circle (or flat) at depth d."""
    tu, tv = setup.target.maps.texel_metres
    measured = 0.0 - float((height.astype(np.float64) * texel_areas(height.shape, setup)).sum())
    groove, drag = setup.groove, setup.drag
    predicted = groove.predicted_volume(drag.distance_m)
    result: dict = {
        "archard_volume_m3": groove.archard_volume,
        "ends_volume_m3": groove.ends_volume,
        "predicted_volume_m3": predicted,
        "measured_volume_m3": measured,
        "ratio": measured / predicted if predicted > 0 else (0.0 if measured == 0 else math.inf),
        "depth_m": groove.depth,
        "half_width_m": groove.half_width,
        "cross_section_m2": groove.area,
        "grooved_texels": int((height < GROOVED).sum()),
    }
    if groove.coat > 0:  # the coat's part and the metal's along the path, and the bare texels
        result["coat_thickness_m"] = groove.coat
        result["coat_volume_m3"] = groove.coat_area * drag.distance_m
        result["metal_volume_m3"] = (groove.area - groove.coat_area) * drag.distance_m
        result["bare_metal_texels"] = int((height < -groove.coat).sum())
    if groove.depth <= 0 or not isinstance(setup.target_shape, Plate):
        return result  # a cube's texels lie in its atlas's cells: its volume alone
    along, off = _path_coordinates(height.shape, setup)
    reach = groove.half_width + 2.0 * max(tu, tv)
    straight = (along > reach + _end_reach(setup)) & (
        along < drag.distance_m - reach - _end_reach(setup)
    )
    near = straight & (np.abs(off) <= reach)
    if near.any():
        expected = _profile(setup.tool_shape, groove.depth, off[near])
        error = -height[near].astype(np.float64) - expected
        result["cross_section_rms_error_m"] = float(np.sqrt(np.mean(error**2)))
        result["cross_section_max_error_m"] = float(np.abs(error).max())
        # The deepest texel of each slice a millimetre long: its depth along the path.
        slices = np.floor(along[near] / 1e-3).astype(np.int64)
        deepest = np.full(slices.max() + 1, 0.0)
        np.maximum.at(deepest, slices, -height[near])
        deepest = deepest[np.unique(slices)]
        result["depth_along_path_m"] = [float(deepest.min()), float(deepest.max())]
    result["grooved_off_path_texels"] = int(((height < GROOVED) & (np.abs(off) > reach)).sum())
    return result


def texel_areas(shape: tuple[int, ...], setup: ScratchSetup) -> NDArray[np.float64] | float:
    """The surface area each texel of the target's map covers, m^2: a sphere's from its atlas's
    closed form (its texels differ in size, gutters 0), a plate's or cube's one texel's."""
    if isinstance(setup.target_shape, Sphere):
        return sphere_texel_areas(setup.target_shape.radius, shape[0], shape[1])
    tu, tv = setup.target.maps.texel_metres
    return tu * tv


def _end_reach(setup: ScratchSetup) -> float:
    """How far past the path's ends the tool's print reaches along it, m."""
    tool = setup.tool_shape
    if isinstance(tool, Box | Plate | Cylinder):
        return _extent(tool) / 2
    return _extent(tool) / 2 + setup.groove.half_width


def _profile(tool: Shape, depth: float, offset: NDArray[np.float64]) -> NDArray[np.float64]:
    """The groove's depth `offset` metres across from its axis (>= 0)."""
    if isinstance(tool, Box | Plate):
        width = tool.size[0] if isinstance(tool, Box) else tool.side
        return np.where(np.abs(offset) < width / 2, depth, 0.0)
    r = tool.radius  # type: ignore[union-attr]
    reach = np.sqrt(np.maximum(r * r - offset * offset, 0.0))
    return np.maximum(depth - (r - reach), 0.0)


def _path_coordinates(
    shape: tuple[int, ...], setup: ScratchSetup
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each texel centre's distance along the path from its start and across it, m (a plate's
    or box top's texels: x = (u - 1/2) side, z = (1/2 - v) side, row 0 at v = 0)."""
    rows, cols = shape
    sx, sz = _face_size(setup.target_shape)
    x = ((np.arange(cols) + 0.5) / cols - 0.5)[None, :] * sx
    z = (0.5 - (np.arange(rows) + 0.5) / rows)[:, None] * sz
    d = setup.direction
    dx, dz = x - setup.start[0], z - setup.start[2]
    along = dx * d[0] + dz * d[2]
    off = dx * -d[2] + dz * d[0]
    return along, off


def _face_size(shape: Shape) -> tuple[float, float]:
    match shape:
        case Plate(side=side):
            return side, side
    raise DentdemoError(f"--target: a scratch is measured on a plate, got {type(shape).__name__}")


def write_scratch(gl: GLContext, setup: ScratchSetup, out: Path, carved: int) -> dict:
    """The target's maps, a 16-bit height PNG scaled to the groove's depth and summary.json."""
    height = gl.read(setup.target.maps.height)[:, :, 0]
    if not np.isfinite(height).all():
        raise DentdemoError("the carve left a height that is not a finite number")
    outputs.write_npy(out / "target_height.npy", height)
    outputs.write_normal_png(out / "target_normal.png", gl.read(setup.target.maps.normal))
    scale = setup.groove.depth if setup.groove.depth > 0 else setup.target.maps.max_dent_depth
    outputs.write_height_png(out / "target_height.png", height, scale)
    drag = setup.drag
    summary = {
        "target": as_dict(setup.target_shape),
        "tool": as_dict(setup.tool_shape),
        "load_N": drag.load_n,
        "distance_m": drag.distance_m,
        "slid_m": drag.slide_m,
        "speed_m_s": drag.speed_m_s,
        "duration_s": drag.distance_m / drag.speed_m_s,
        "map_size": list(setup.target.maps.size),
        "texel_m": list(setup.target.maps.texel_metres),
        "segments": len(setup.segments),
        "segment_length_m": setup.segment_length,
        "carved_directions": carved,
        "renderer": gl.renderer,
        **measure(height, setup),
    }
    outputs.write_json(out / "summary.json", summary)
    return summary
