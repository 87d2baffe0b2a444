"""Saving and resuming damage: a folder with every body's height map (float32, exact), the physics
state as ODE holds it, the carves still queued, the scene it came from and a format version.
Resuming continues bit for bit as if the run had never stopped.

Layout of a state folder:
    state.json          format, version, scene (path, sha256), time, bodies, queue, counters
    <body id>.npy       height map of each dentable body, float32 [v, u], metres

A save writes a new folder beside the old one and swaps it in (outputs.write_folder); a load
reads and checks everything (`read_state`) before it changes anything (`apply_state`).
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
import sys
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dentdemo import outputs
from dentdemo.app.compact import (
    CHECKPOINT_FILE,
    EVERY_HITS,
    LOG_FILE,
    Checkpoint,
    CompactSaves,
    normal_file,
)
from dentdemo.app.compact import sha256 as _sha256
from dentdemo.app.hitlog import MAX_LOG_BYTES, replay
from dentdemo.app.reshape import DentProxy, proxy_for
from dentdemo.app.simulation import (
    CARVED_POINTS_KEPT,
    CarveRequest,
    Simulation,
    map_side,
)
from dentdemo.app.stats import SimStats
from dentdemo.app.wear import SavedWear, read_wear
from dentdemo.carve.surface import MAX_MAP_SIZE, rebuild_all_normals
from dentdemo.errors import ArgumentError, DentdemoError
from dentdemo.mesh.shapes import shape_mesh
from dentdemo.model import hitlog, shapes
from dentdemo.model.hitlog import Record
from dentdemo.model.scene import BOUNDS, SHAPE_KINDS, BodySpec, is_safe_name
from dentdemo.model.shapes import Plane
from dentdemo.model.validate import TOML_MAX, TableReader, read_input
from dentdemo.physics.world import Impact, WorldState

FORMAT = "dentdemo-state"
VERSION = 1
STATE_FILE = "state.json"

#: Plausibility bounds of a saved run, beyond which a value is damage, not a run: a scene starts
#: its bodies within BOUNDS.position m and BOUNDS.speed m/s; a thousand times that leaves room
#: for anything a run reaches, while ODE still steps it without overflow.
REACH = 1e3 * BOUNDS.position  # m from the origin
SPEED = 1e3 * max(BOUNDS.speed, BOUNDS.spin)  # m/s, rad/s
#: How far a saved quaternion's (or normal's) length may be from 1 (ODE keeps it within 1e-15).
UNIT_TOLERANCE = 1e-6
#: How far the saved time may be from step_index x dt, relative (float sums of substeps).
TIME_TOLERANCE = 1e-6
#: Counters (steps, frames, hits): whole numbers a float64 holds exactly.
COUNT_MAX = 2**53
#: ODE's random seed is 32 bits (dRandGetSeed).
SEED_MAX = 2**32 - 1
#: Most bodies added while running, and queued carves, a state may hold.
ENTRIES_MAX = 10**6
#: The largest state.json read, bytes: a queued carve is about 2 kB as JSON and an added body
#: 0.6 kB, so this holds some 100,000 of them (a saved run holds tens).
STATE_JSON_MAX = 256 << 20
#: Room for a .npy file's header beside its data, bytes (np.save writes 128).
NPY_HEADER_MAX = 4096


def _scene_hash(sim: Simulation) -> str:
    try:
        return _sha256(read_input(Path(sim.scene.source), TOML_MAX))
    except OSError as exc:
        raise DentdemoError(f"{sim.scene.source}: cannot read the scene ({exc.strerror})") from None


def _plain(value: Any) -> Any:
    """JSON-ready: arrays and tuples as lists (floats keep every bit through JSON)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


def _impact_dict(impact: Impact) -> dict[str, Any]:
    return {f.name: _plain(getattr(impact, f.name)) for f in dataclasses.fields(impact)}


def _added_body(spec: BodySpec) -> dict[str, Any]:
    """A body added while running (the demo's balls and plates): its spec, material by name."""
    fields = {f.name: _plain(getattr(spec, f.name)) for f in dataclasses.fields(spec)}
    fields["shape"] = shapes.as_dict(spec.shape)
    fields["material"] = spec.material.name
    return fields


# -- saving ------------------------------------------------------------------------------------
def is_state_file(name: str) -> bool:
    """The files a state folder holds: state.json and the height maps, and a compact state's
    hit log and checkpoint (whose normal maps are .npy files too)."""
    return name in (STATE_FILE, LOG_FILE, CHECKPOINT_FILE) or name.endswith(".npy")


def check_state_dir(flag: str, directory: Path) -> Path:
    """Where a state can be saved: a new folder, an empty one or an earlier state (it is
    replaced as a whole); checked before any work."""
    return outputs.check_replaceable_dir(flag, directory, is_state_file, "a saved state")


def _snapshot(
    sim: Simulation, with_maps: bool = True
) -> tuple[dict[str, Any], dict[str, bytes], dict[str, np.ndarray]]:
    """state.json's payload, the .npy files' bytes and the heights they hold, as they are now
    (`with_maps` False: none listed nor read back, for a compact save)."""
    scene_ids = {spec.id for spec in sim.scene.bodies}
    world = sim.world.snapshot()
    maps: dict[str, dict[str, Any]] = {}
    files: dict[str, bytes] = {}
    heights: dict[str, np.ndarray] = {}
    for body_id, body in sorted(sim.bodies.items()):
        if not body.spec.dentable or not with_maps:
            continue
        height = np.ascontiguousarray(sim.gl.read(body.maps.height)[:, :, 0], dtype=np.float32)
        data = outputs.npy_bytes(height)  # written as is, and hashed
        name = f"{body_id}.npy"
        files[name] = data
        heights[body_id] = height
        maps[body_id] = {"file": name, "shape": list(height.shape), "sha256": _sha256(data)}
    payload = {
        "format": FORMAT,
        "version": VERSION,
        "scene": {"file": str(sim.scene.source), "sha256": _scene_hash(sim)},
        "world": dataclasses.asdict(world),
        "added_bodies": [
            _added_body(body.spec)
            for body_id, body in sim.bodies.items()
            if body_id not in scene_ids
        ],
        "maps": maps,
        "queue": [
            {
                "impact": _impact_dict(r.impact),
                "depth_a": r.depth_a,
                "depth_b": r.depth_b,
                "model_a": _plain(r.model_a),
                "model_b": _plain(r.model_b),
            }
            for r in sim.queue
        ],
        "shapes": {
            body_id: {
                "points": np.nonzero(proxy.inward)[0].tolist(),
                "inward": proxy.inward[proxy.inward > 0].tolist(),
                "shaped": proxy.shaped[proxy.inward > 0].tolist(),
                "rebuilt_at": proxy.rebuilt_at,
            }
            for body_id, proxy in sorted(sim.proxies.items())
        },
        "carved_points": [_plain(p) for p in sim.carved_points],
        "stats": dataclasses.asdict(sim.stats),
        "ball_count": sim.ball_count,
    }
    if sim.wear is not None:  # a slide under way (app/wear.py)
        payload["wear"] = sim.wear.saved()
    return payload, files, heights


def save_state(sim: Simulation, directory: Path, flag: str = "--save-state") -> Path:
    """Write the simulation's state as the folder `directory`: the height maps and state.json
    go into a new folder beside it, which then replaces the previous one as a whole
    (outputs.write_folder), so a kill at any moment leaves the previous state or the new one.
    With compact saves on (`enable_compact_saves`), the maps are a checkpoint and the hit log
    since it instead (app/compact.py). The state is first checked as a load checks it: what a
    load would refuse (NaN above all) is never saved. Returns the path of state.json."""
    check_state_dir(flag, directory)
    saves = sim.compact_saves
    if saves is not None and saves.due():
        saves.checkpoint_now(sim, checkpoint_of(sim))
    payload, files, heights = _snapshot(sim, with_maps=saves is None)
    if saves is not None:
        keys, extra = saves.contents()
        payload.update(keys)
        files.update(extra)
        if saves.checkpoint is not None:
            heights = dict(saves.checkpoint.heights)
    text = json.dumps(payload, indent=2) + "\n"

    def in_memory(
        r: TableReader, body_id: str, file: str, sha: str, shape: tuple[int, int]
    ) -> NDArray[np.float32]:
        return _checked_height(directory / file, heights[body_id])

    try:
        _parse(sim, json.loads(text), directory / STATE_FILE, in_memory, files.__getitem__)
    except DentdemoError as exc:
        raise DentdemoError(f"{flag}: not saved, a load would refuse it: {exc}") from None
    files[STATE_FILE] = text.encode("utf-8")
    return outputs.write_folder(directory, files, flag) / STATE_FILE


def checkpoint_of(sim: Simulation) -> Checkpoint:
    """`sim` as a full state in memory, with its normal maps (all read back from the GPU)."""
    payload, files, heights = _snapshot(sim)
    normals = {body_id: sim.gl.read(sim.bodies[body_id].maps.normal) for body_id in heights}
    for body_id, normal in normals.items():
        files[normal_file(body_id)] = outputs.npy_bytes(normal)
    return Checkpoint(payload, files, heights, normals)


def enable_compact_saves(sim: Simulation, every_hits: int = EVERY_HITS) -> CompactSaves:
    """Keep `sim`'s saves compact from now on (app/compact.py). A run that has carved nothing
    needs no checkpoint (the scene as loaded is one); otherwise its maps are read back as the
    first."""
    saves = CompactSaves(every_hits)
    sim.compact_saves = saves
    saves.recorder.attach(sim)
    if sim.stats.hits > 0:
        saves.checkpoint_now(sim, checkpoint_of(sim))
    return saves


# -- loading -----------------------------------------------------------------------------------
def _map_side(sim: Simulation, spec: BodySpec) -> int:
    body = sim.bodies.get(spec.id)
    if body is not None and body.spec == spec:
        return int(body.maps.size[0])
    return map_side(spec, shape_mesh(spec.shape))


@dataclass(frozen=True)
class SavedState:
    """A state folder read and checked in full: what `apply_state` sets, nothing left to fail."""

    world: WorldState
    #: Bodies added while running, in the order they were added.
    added: tuple[BodySpec, ...]
    #: Scene bodies the saved run had lost (non-finite, physics/world.py).
    removed: tuple[str, ...]
    #: Each dentable body's height map, float32 [v, u], metres.
    heights: dict[str, NDArray[np.float32]]
    queue: tuple[CarveRequest, ...]
    #: Collision shapes that follow dents (app/reshape.py), by body, pressed as they were saved.
    shapes: dict[str, DentProxy]
    #: World metres.
    carved_points: tuple[NDArray[np.float64], ...]
    stats: SimStats
    ball_count: int
    #: A compact state: the hit log since its checkpoint (records, and where each is in the
    #: file), and the checkpoint (None: the scene as loaded), read and checked in full too.
    log: tuple[Record, ...] | None = None
    log_places: tuple[str, ...] = ()
    checkpoint: SavedState | None = None
    checkpoint_kept: Checkpoint | None = None
    #: Scratches under way (app/wear.py), where the scene wears.
    wear: SavedWear | None = None


#: Reads one height map: (its entry in `maps`, body id, file name, sha256, shape (v, u)).
MapReader = Callable[[TableReader, str, str, str, tuple[int, int]], NDArray[np.float32]]


def _checked_height(path: Path, height: NDArray[np.float32]) -> NDArray[np.float32]:
    if not np.isfinite(height).all():
        raise DentdemoError(f"{path}: holds NaN or infinity")
    return height


#: Float32 rounding of a bound (max_dent_depth, bump_height) held in a map, relative.
HEIGHT_TOLERANCE = 1e-6


def _within(path: Path, height: NDArray[np.float32], spec: BodySpec) -> NDArray[np.float32]:
    """A map's heights within what the body can hold: no dent deeper than its material's
    max_dent_depth (the carve's clamp), nothing above its start surface (0, or its bump map's
    white: dents only lower a surface), metres."""
    deepest = spec.material.max_dent_depth
    top = spec.bump_height if spec.bump_map else 0.0
    low, high = -deepest * (1.0 + HEIGHT_TOLERANCE), top * (1.0 + HEIGHT_TOLERANCE)
    if height.size and (height.min() < low or height.max() > high):
        raise DentdemoError(
            f"{path}: heights from {height.min():.6g} to {height.max():.6g} m, outside "
            f"[{-deepest:g}, {top:g}] m (no dent deeper than {spec.material.name}'s "
            "max_dent_depth, nothing above the start surface)"
        )
    return height


def _maps_in(directory: Path) -> MapReader:
    """Height maps from the files of `directory`. Where a file's bytes differ from state.json's
    hash, the file is blamed when it is not a complete map of the listed shape (truncated,
    damaged), and state.json when the file is a complete map (state.json is the stale one)."""

    def read(
        r: TableReader, body_id: str, file: str, sha: str, shape: tuple[int, int]
    ) -> NDArray[np.float32]:
        path = directory / file
        try:
            data = read_input(path, shape[0] * shape[1] * 4 + NPY_HEADER_MAX)
        except FileNotFoundError:
            raise DentdemoError(f"{path}: missing (state.json lists it)") from None
        except OSError as exc:
            raise DentdemoError(f"{path}: cannot read ({exc.strerror})") from None
        buffer = io.BytesIO(data)
        try:
            height = np.load(buffer, allow_pickle=False)
        except (ValueError, OSError, EOFError):
            height = None
        if height is not None and buffer.tell() != len(data):
            raise DentdemoError(
                f"{path}: {len(data) - buffer.tell()} bytes after the map's data (damaged)"
            )
        complete = (
            isinstance(height, np.ndarray) and height.dtype == np.float32 and height.shape == shape
        )
        if _sha256(data) != sha and complete:
            raise r.fail(
                "sha256",
                f"differs from {file}, a complete {shape[1]}x{shape[0]} map: state.json is "
                f"stale (left by another save) or {file} was replaced",
            )
        if _sha256(data) != sha or height is None or not complete:
            raise DentdemoError(
                f"{path}: truncated or damaged ({len(data)} bytes, not the float32 "
                f"{shape[1]}x{shape[0]} map state.json lists)"
            )
        return _checked_height(path, height)

    return read


def _quaternion(r: TableReader, key: str) -> tuple[float, float, float, float]:
    """A unit quaternion (w, x, y, z)."""
    w, x, y, z = r.vector(key, None, 4)
    length = math.hypot(w, x, y, z)
    if abs(length - 1.0) > UNIT_TOLERANCE:
        raise r.fail(key, f"must be a unit quaternion (w, x, y, z); its length is {length:.6g}")
    return w, x, y, z


def _entries(r: TableReader, key: str, names: tuple[str, ...]) -> TableReader:
    """A list of len(names) values, read as a table of those names (messages name the item)."""
    value = r.raw(key)
    if not isinstance(value, list) or len(value) != len(names):
        raise r.fail(key, f"must be a list [{', '.join(names)}]")
    return TableReader(r.source, f"{r.table_name}.{key}", dict(zip(names, value, strict=True)))


def _pose(r: TableReader, key: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(position m, quaternion w x y z)."""
    p = _entries(r, key, ("position", "quaternion"))
    position = p.vector("position", None, 3, REACH, "distance from the origin (m)")
    return np.asarray(position, dtype=np.float64), np.asarray(_quaternion(p, "quaternion"))


def _matrix(r: TableReader, key: str) -> NDArray[np.float64]:
    """A 4x4 model matrix, finite, last row 0 0 0 1, translation within REACH."""
    value = r.raw(key)
    rows = value if isinstance(value, list) and len(value) == 4 else []
    ok = len(rows) == 4 and all(
        isinstance(row, list)
        and len(row) == 4
        and all(isinstance(x, int | float) and not isinstance(x, bool) for x in row)
        for row in rows
    )
    try:
        m = np.asarray(rows, dtype=np.float64) if ok else np.zeros((4, 4))
    except OverflowError:  # an integer beyond float range
        ok, m = False, np.zeros((4, 4))
    if not ok or not np.isfinite(m).all() or not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
        raise r.fail(key, "must be a 4x4 model matrix of finite numbers, last row 0 0 0 1")
    if np.abs(m[:3, 3]).max() > REACH:
        raise r.fail(key, f"its translation lies beyond {REACH:g} m")
    return m


def _mass(r: TableReader, key: str) -> float:
    """kg, > 0; infinite for a static body."""
    value = r.raw(key)
    if isinstance(value, float) and value == math.inf:
        return math.inf
    return r.positive(key)


def _shape(r: TableReader) -> shapes.Shape:
    """A body's shape as shapes.as_dict wrote it, sizes within the scene files' bounds."""
    kind = r.string("kind", choices=SHAPE_KINDS)
    cls: Any = shapes.KINDS[kind]
    fields: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if f.name == "size":
            fields[f.name] = r.vec3(f.name, None)
            if not all(BOUNDS.size_min <= x <= BOUNDS.size_max for x in fields[f.name]):
                raise r.fail(
                    f.name, f"edges must lie in [{BOUNDS.size_min:g}, {BOUNDS.size_max:g}] m"
                )
        elif f.name == "path":
            fields[f.name] = r.string(f.name)
            if not Path(fields[f.name]).is_file():
                raise r.fail(f.name, "no such file")
        elif f.name == "scale":
            fields[f.name] = r.number(
                f.name, None, min_value=0.0, min_inclusive=False, max_value=BOUNDS.mesh_scale_max
            )
        else:
            fields[f.name] = r.number(
                f.name, None, min_value=BOUNDS.size_min, max_value=BOUNDS.size_max
            )
    r.finish()
    try:
        shape: shapes.Shape = cls(**fields)
    except ArgumentError as exc:
        raise r.fail("kind", str(exc)) from None
    return shape


def _added(sim: Simulation, r: TableReader, taken: dict[str, BodySpec]) -> BodySpec:
    """A body added while running, as _added_body wrote it."""
    body_id = r.string("id")
    if not is_safe_name(body_id) or body_id in taken:
        raise r.fail("id", "must be a safe file name that no other body has")
    shape = _shape(r.table_at("shape"))
    material = sim.materials.get(r.string("material"), r.source, f"[{r.table_name}] key 'material'")
    static = r.boolean("static", False)
    if isinstance(shape, Plane) and not static:
        raise r.fail("static", "a plane is always static")
    spec = BodySpec(
        id=body_id,
        shape=shape,
        material=material,
        position=r.vec3("position", None, REACH, "distance from the origin (m)"),
        orientation=_quaternion(r, "orientation"),
        velocity=r.vec3("velocity", None, SPEED, "speed (m/s)"),
        angular_velocity=r.vec3("angular_velocity", None, SPEED, "spin (rad/s)"),
        static=static,
        texels_per_metre=r.number(
            "texels_per_metre", None, min_value=1.0, max_value=BOUNDS.texels_per_metre_max
        ),
        dentable=r.boolean("dentable", True),
        bump_map=r.string("bump_map", ""),
        bump_height=r.number("bump_height", 0.0, min_value=0.0, max_value=BOUNDS.bump_height_max),
    )
    if spec.bump_map and not Path(spec.bump_map).is_file():
        raise r.fail("bump_map", "no such file")
    r.finish()
    try:
        _map_side(sim, spec)  # its mesh builds (a mesh file loads)
    except DentdemoError as exc:
        raise r.fail("shape", str(exc)) from None
    return spec


def _world(sim: Simulation, w: TableReader, specs: dict[str, BodySpec]) -> WorldState:
    """The physics: the time consistent with the step count; every added body and each scene
    body once in `order` (a scene body missing from it was lost by the saved run); for each
    moving body a pose and velocities within the bounds and a unit quaternion."""
    step_index = w.integer("step_index", min_value=0, max_value=COUNT_MAX)
    time = w.number("time", None, min_value=0.0)
    expected = step_index * sim.scene.physics.dt
    if abs(time - expected) > TIME_TOLERANCE * max(1.0, expected):
        raise w.fail("time", f"must be step_index x dt = {expected:.9g} s")
    seed = w.integer("seed", min_value=0, max_value=SEED_MAX)
    order = w.raw("order")
    if not isinstance(order, list) or not all(isinstance(x, str) for x in order):
        raise w.fail("order", "must be a list of body ids")
    for body_id in order:
        if body_id not in specs:
            raise w.fail("order", f"body '{body_id}' is neither in the scene nor added")
    if len(set(order)) != len(order):
        twice = next(x for x in order if order.count(x) > 1)
        raise w.fail("order", f"body '{twice}' is listed twice")
    scene_ids = {spec.id for spec in sim.scene.bodies}
    lost = [body_id for body_id in specs if body_id not in order and body_id not in scene_ids]
    if lost:
        raise w.fail("order", f"added body '{lost[0]}' is missing from it")
    moving = [
        body_id
        for body_id in order
        if not specs[body_id].static and not isinstance(specs[body_id].shape, Plane)
    ]
    b = w.table_at("bodies")
    for body_id in b.table:
        if body_id not in moving:
            raise b.fail(body_id, "is not a moving body of world.order")
    bodies: dict[str, tuple[list[float], list[float], list[float], list[float]]] = {}
    for body_id in moving:
        e = _entries(b, body_id, ("position", "quaternion", "velocity", "angular_velocity"))
        bodies[body_id] = (
            list(e.vector("position", None, 3, REACH, "distance from the origin (m)")),
            list(_quaternion(e, "quaternion")),
            list(e.vector("velocity", None, 3, SPEED, "speed (m/s)")),
            list(e.vector("angular_velocity", None, 3, SPEED, "spin (rad/s)")),
        )
    b.finish()
    w.finish()
    return WorldState(time, step_index, seed, list(order), bodies)


def _impact(r: TableReader, order: list[str]) -> Impact:
    """A queued impact, as _impact_dict wrote it, between two bodies of the world."""

    def body(key: str) -> str:
        body_id = r.string(key)
        if body_id not in order:
            raise r.fail(key, "is not a body of world.order")
        return body_id

    def vec(key: str, bound: float, what: str) -> NDArray[np.float64]:
        return np.asarray(r.vector(key, None, 3, bound, what), dtype=np.float64)

    impact = Impact(
        step=r.integer("step", min_value=0, max_value=COUNT_MAX),
        time=r.number("time", None, min_value=0.0),
        body_a=body("body_a"),
        body_b=body("body_b"),
        point=vec("point", REACH, "distance from the origin (m)"),
        normal=vec("normal", 1.0 + UNIT_TOLERANCE, "length"),
        depth=r.number("depth", None, min_value=0.0, max_value=BOUNDS.size_max),
        vel_a=vec("vel_a", SPEED, "speed (m/s)"),
        vel_b=vec("vel_b", SPEED, "speed (m/s)"),
        mass_a=_mass(r, "mass_a"),
        mass_b=_mass(r, "mass_b"),
        eps_a=r.number("eps_a", None, min_value=0.0, max_value=1.0),
        eps_b=r.number("eps_b", None, min_value=0.0, max_value=1.0),
        j=r.number("j", None),
        j_elastic=r.number("j_elastic", None),
        pose_a=_pose(r, "pose_a"),
        pose_b=_pose(r, "pose_b"),
    )
    r.finish()
    return impact


def _request(r: TableReader, specs: dict[str, BodySpec], order: list[str]) -> CarveRequest:
    """A queued carve: the impact, both depths (m, up to each material's deepest dent) and the
    model matrices at first touch."""
    impact = _impact(r.table_at("impact"), order)

    def depth(key: str, body_id: str) -> float:
        deepest = specs[body_id].material.max_dent_depth
        return r.number(key, None, min_value=0.0, max_value=deepest)

    request = CarveRequest(
        impact,
        depth("depth_a", impact.body_a),
        depth("depth_b", impact.body_b),
        _matrix(r, "model_a"),
        _matrix(r, "model_b"),
    )
    r.finish()
    return request


def _stats(r: TableReader) -> SimStats:
    """Counters (whole numbers) and timings (ms), none negative."""
    values: dict[str, Any] = {}
    for f in dataclasses.fields(SimStats):
        if isinstance(f.default, int):
            values[f.name] = r.integer(f.name, min_value=0, max_value=COUNT_MAX)
        else:
            values[f.name] = r.number(f.name, None, min_value=0.0)
    r.finish()
    return SimStats(**values)


def _parse(
    sim: Simulation,
    payload: Any,
    path: Path,
    read_map: MapReader,
    read_file: Callable[[str], bytes] | None = None,
) -> SavedState:
    """Every key and value of state.json (at `path`) checked against the simulation's scene,
    each height map read by `read_map`; the first fault is a ConfigError naming state.json, the
    key and the value (or a DentdemoError naming the map file)."""
    source = str(path)
    top = TableReader(source, "", payload)
    if top.string("format") != FORMAT:
        raise top.fail("format", f"must be {FORMAT!r}: not a dentdemo state")
    version = top.integer("version", min_value=0, max_value=COUNT_MAX)
    if version != VERSION:
        raise top.fail("version", f"version is {version}; this dentdemo reads {VERSION}")
    scene = top.table_at("scene")
    scene.string("file")
    if scene.string("sha256") != _scene_hash(sim):
        raise scene.fail(
            "sha256",
            f"saved from scene {scene.table['file']}, which differs from {sim.scene.source} "
            "(sha256 of the file)",
        )
    scene.finish()
    specs = {spec.id: spec for spec in sim.scene.bodies}
    added = []
    for i, entry in enumerate(top.items("added_bodies", ENTRIES_MAX)):
        spec = _added(sim, TableReader(source, f"added_bodies[{i}]", entry), specs)
        specs[spec.id] = spec
        added.append(spec)
    world = _world(sim, top.table_at("world"), specs)
    compact = _compact(sim, top, path, read_map, read_file) if top.has("hit_log") else None
    m = top.table_at("maps")
    dentable = [body_id for body_id in world.order if specs[body_id].dentable]
    if compact is not None:
        dentable = []  # the log rebuilds the maps
        for body_id in m.table:
            raise m.fail(body_id, "a compact state lists no maps (its hit log rebuilds them)")
    for body_id in m.table:
        if body_id not in dentable:
            raise m.fail(body_id, "is not a dentable body of world.order")
    heights = {}
    for body_id in dentable:
        r = m.table_at(body_id)
        file = r.string("file")
        if file != f"{body_id}.npy":
            raise r.fail("file", f"must be '{body_id}.npy'")
        side = _map_side(sim, specs[body_id])
        if r.raw("shape") != [side, side]:
            raise r.fail("shape", f"does not fit body '{body_id}' ({side}x{side} texels)")
        sha = r.string("sha256")
        r.finish()
        heights[body_id] = _within(
            path.parent / file, read_map(r, body_id, file, sha, (side, side)), specs[body_id]
        )
    m.finish()
    queue = tuple(
        _request(TableReader(source, f"queue[{i}]", entry), specs, world.order)
        for i, entry in enumerate(top.items("queue", ENTRIES_MAX))
    )
    shapes = _shapes(sim, top, specs, world.order) if top.has("shapes") else {}
    points = []
    for i, point in enumerate(top.items("carved_points", CARVED_POINTS_KEPT)):
        p = TableReader(source, f"carved_points[{i}]", {"point": point})
        points.append(np.asarray(p.vector("point", None, 3, REACH, "distance from the origin")))
    state = SavedState(
        world=world,
        added=tuple(added),
        removed=tuple(spec.id for spec in sim.scene.bodies if spec.id not in world.order),
        heights=heights,
        queue=queue,
        shapes=shapes,
        carved_points=tuple(points),
        stats=_stats(top.table_at("stats")),
        ball_count=top.integer("ball_count", min_value=0, max_value=COUNT_MAX),
        wear=read_wear(top.table_at("wear"), set(world.order)) if top.has("wear") else None,
    )
    if compact is not None:
        state = dataclasses.replace(state, **compact)
    top.finish()
    return state


def _compact(
    sim: Simulation,
    top: TableReader,
    path: Path,
    read_map: MapReader,
    read_file: Callable[[str], bytes] | None,
) -> dict[str, Any]:
    """A compact state's `hit_log` and `checkpoint`: each file read, its sha256 checked, the log
    parsed and checked whole (model/hitlog.py), the checkpoint parsed as a full state."""
    folder = path.parent

    def read(table: TableReader, name: str) -> bytes:
        if table.string("file") != name:
            raise table.fail("file", f"must be '{name}'")
        data = read_raw(folder, name)
        if table.string("sha256") != _sha256(data):
            raise table.fail("sha256", f"differs from {name}'s bytes")
        return data

    def read_raw(folder: Path, name: str) -> bytes:
        if read_file is None:
            raise DentdemoError(f"{folder / name}: a compact state needs its folder")
        try:
            return read_file(name)
        except (OSError, KeyError):
            raise DentdemoError(f"{folder / name}: missing or unreadable") from None

    h = top.table_at("hit_log")
    data = read(h, LOG_FILE)
    hits = h.integer("hits", min_value=0, max_value=COUNT_MAX)
    h.finish()
    try:
        records, places = hitlog.parse_placed(data, str(folder / LOG_FILE))
    except hitlog.HitLogError as exc:
        raise DentdemoError(str(exc)) from None
    if hits != sum(isinstance(r, hitlog.Hit | hitlog.Groove) for r in records):
        raise h.fail("hits", f"is {hits}; {LOG_FILE} holds another number")
    found: dict[str, Any] = {"log": tuple(records), "log_places": tuple(places)}
    if top.has("checkpoint") and top.raw("checkpoint") is not None:
        c = top.table_at("checkpoint")
        text = read(c, CHECKPOINT_FILE)
        try:
            inner = json.loads(text.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
            raise DentdemoError(f"{folder / CHECKPOINT_FILE}: not JSON ({exc})") from None
        if isinstance(inner, dict) and "hit_log" in inner:
            raise c.fail("file", "a checkpoint is a full state, not a compact one")
        checkpoint = _parse(sim, inner, folder / CHECKPOINT_FILE, read_map)
        normals = _normals(c.table_at("normals"), checkpoint, lambda n: read_raw(folder, n))
        c.finish()
        files = {f"{b}.npy": outputs.npy_bytes(v) for b, v in checkpoint.heights.items()}
        files.update({normal_file(b): outputs.npy_bytes(v) for b, v in normals.items()})
        found["checkpoint"] = checkpoint
        found["checkpoint_kept"] = Checkpoint(inner, files, dict(checkpoint.heights), normals)
    return found


def _shapes(
    sim: Simulation, top: TableReader, specs: dict[str, BodySpec], order: list[str]
) -> dict[str, DentProxy]:
    """`shapes`: per dynamic dentable body of world.order, its pressed vertices (strictly
    increasing indices into its proxy), how far each is in and how far its geom holds it
    (0 <= shaped <= inward <= the material's deepest dent), the depth at the last rebuild; as
    proxies pressed so."""
    t = top.table_at("shapes")
    out = {}
    for body_id in t.table:
        spec = specs.get(body_id)
        if body_id not in order or spec is None or spec.static or not spec.dentable:
            raise t.fail(body_id, "is not a dynamic dentable body of world.order")
        r = t.table_at(body_id)
        body = sim.bodies.get(body_id)
        proxy = proxy_for(spec.shape, body.mesh if body is not None else shape_mesh(spec.shape))
        vertices = len(proxy.points)
        deepest = spec.material.max_dent_depth
        points = r.items("points", vertices)
        if not all(isinstance(k, int) and not isinstance(k, bool) for k in points) or (
            points and (points[0] < 0 or points[-1] >= vertices or np.any(np.diff(points) <= 0))
        ):
            raise r.fail("points", f"must be increasing vertex indices in [0, {vertices})")
        values = {}
        for key in ("inward", "shaped"):
            array = np.asarray(r.vector(key, None, len(points)), dtype=np.float64)
            if np.any(array < 0) or np.any(array > deepest):
                raise r.fail(key, f"must lie in [0, {deepest:g}] m (the material's deepest dent)")
            values[key] = array
        if np.any(values["shaped"] > values["inward"]):
            raise r.fail("shaped", "must not exceed 'inward' (dents only deepen)")
        proxy.rebuilt_at = r.number("rebuilt_at", min_value=0.0, max_value=deepest)
        r.finish()
        proxy.inward[points], proxy.shaped[points] = values["inward"], values["shaped"]
        out[body_id] = proxy
    t.finish()
    return out


def read_state(sim: Simulation, directory: Path) -> SavedState:
    """state.json and the height maps of `directory`, every check done, nothing changed."""
    path = directory / STATE_FILE
    if not directory.is_dir():
        left = outputs.leftovers_beside(directory, outputs.OLD_FOLDER)
        if not directory.exists() and left:
            raise DentdemoError(
                f"--load-state: '{directory}' is missing: a save was killed while swapping "
                f"folders; the previous state is '{left[-1]}' (rename it to '{directory.name}')"
            )
        raise DentdemoError(f"--load-state: '{directory}' is not a folder")
    try:
        payload = json.loads(read_input(path, STATE_JSON_MAX).decode("utf-8"))
    except FileNotFoundError:
        raise DentdemoError(f"{path}: missing; '{directory}' is not a saved state") from None
    except OSError as exc:
        raise DentdemoError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise DentdemoError(f"{path}: not a readable state file ({type(exc).__name__})") from None
    except ValueError:  # an integer of more digits than Python converts (4300)
        raise DentdemoError(
            f"{path}: not a readable state file (a number of more than "
            f"{sys.get_int_max_str_digits()} digits)"
        ) from None
    return _parse(sim, payload, path, _maps_in(directory), _compact_files(directory))


def _compact_files(directory: Path) -> Callable[[str], bytes]:
    """A compact state's other files, each a regular file read up to its bound."""

    def read(name: str) -> bytes:
        if name == LOG_FILE:
            limit = MAX_LOG_BYTES
        elif name.endswith(".json"):
            limit = STATE_JSON_MAX
        else:  # an RGBA8 normal map
            limit = MAX_MAP_SIZE * MAX_MAP_SIZE * 4 + NPY_HEADER_MAX
        return read_input(directory / name, limit)

    return read


def apply_state(sim: Simulation, state: SavedState) -> None:
    """Set a checked state: the simulation is reset to its scene first, so loading in a running
    demo equals loading in a new process. A compact state's checkpoint is set first and its hit
    log carved onto it. A hit log being written (--hit-log) stops here (its records carve from
    the scene as loaded; the state's maps are not carves); compact saves go on from the state."""
    saves = sim.compact_saves
    for recorder in list(sim.recorders):
        if saves is None or recorder is not saves.recorder:
            recorder.stop(sim, "a saved state was loaded")
    if saves is not None:
        sim.recorders.remove(saves.recorder)  # the load's own carves are not recorded
    if state.log is None:
        _apply_full(sim, state)
    else:
        _apply_compact(sim, state)
    if saves is not None:
        sim.recorders.append(saves.recorder)
        if state.log is None:
            saves.checkpoint_now(sim, checkpoint_of(sim))
        else:
            saves.resume(sim, list(state.log), state.checkpoint_kept)


def _normals(
    t: TableReader, checkpoint: SavedState, read: Callable[[str], bytes]
) -> dict[str, NDArray[np.uint8]]:
    """A checkpoint's normal maps: one per height map, RGBA8 of its side, hashes checked."""
    out = {}
    for body_id, height in checkpoint.heights.items():
        r = t.table_at(body_id)
        name = normal_file(body_id)
        if r.string("file") != name:
            raise r.fail("file", f"must be '{name}'")
        data = read(name)
        if r.string("sha256") != _sha256(data):
            raise r.fail("sha256", f"differs from {name}'s bytes")
        r.finish()
        try:
            normal = np.load(io.BytesIO(data), allow_pickle=False)
        except (ValueError, OSError, EOFError):
            normal = None
        shape = (*height.shape, 4)
        if not isinstance(normal, np.ndarray) or normal.dtype != np.uint8 or normal.shape != shape:
            raise DentdemoError(f"{name}: not an RGBA8 map of {shape[1]}x{shape[0]} texels")
        out[body_id] = normal
    t.finish()
    return out


def _apply_full(sim: Simulation, state: SavedState) -> None:
    sim.reset()
    for body_id in state.removed:
        sim.remove_body(body_id)  # lost during the saved run (non-finite)
    for spec in state.added:
        sim.add_body(spec)
    for body_id, height in state.heights.items():
        body = sim.bodies[body_id]
        body.maps.height.write(height.tobytes())
        rebuild_all_normals(sim.gl, body.gpu_mesh, body.maps)
    _apply_rest(sim, state)


def _apply_compact(sim: Simulation, state: SavedState) -> None:
    """The checkpoint (or the scene), then the log carved onto it. The bodies added while
    running are added in their order once the log's last reset is carved (the world's order is
    part of the physics), each dented one then found by its id, and the bodies the run lost are
    removed after the log (their dents are part of it)."""
    assert state.log is not None
    if state.checkpoint is not None:
        _apply_full(sim, state.checkpoint)
        assert state.checkpoint_kept is not None
        for body_id, normal in state.checkpoint_kept.normals.items():
            sim.bodies[body_id].maps.normal.write(normal.tobytes())  # as the carve left them
    else:
        sim.reset()
    records, places = list(state.log), list(state.log_places)
    cut = max(
        (i + 1 for i, r in enumerate(records) if getattr(r, "kind", "") == "reset"), default=0
    )
    replay(sim, records[:cut], places[:cut])
    for spec in state.added:
        if spec.id not in sim.bodies:
            sim.add_body(spec)
    replay(sim, records[cut:], places[cut:], present={spec.id for spec in state.added})
    sim.undo_log.clear()  # as after a full load: the undo history is not saved
    for body_id in state.removed:
        if body_id in sim.bodies:
            sim.remove_body(body_id)
    _apply_rest(sim, state)


def _apply_rest(sim: Simulation, state: SavedState) -> None:
    sim.world.restore(state.world)
    for body_id, proxy in state.shapes.items():
        sim.proxies[body_id] = proxy
        if proxy.rebuilt_at > 0.0:
            sim.world.set_surface(body_id, *proxy.surface())
    sim.queue = deque(state.queue)
    sim.carved_points.clear()
    sim.carved_points.extend(state.carved_points)
    sim.stats = dataclasses.replace(state.stats)
    sim.ball_count = state.ball_count
    if sim.wear is not None and state.wear is not None:
        sim.wear.restore(state.wear)


def load_state(sim: Simulation, directory: Path) -> None:
    """Resume from `directory`: bodies, maps (normals rebuilt on the GPU), physics, queue. All or
    nothing: the folder is read and checked in full (`read_state`) before anything changes."""
    apply_state(sim, read_state(sim, directory))
