"""A Simulation's carves as hit-log records (model/hitlog.py), and a log carved back onto a
Simulation's bodies with no physics: the same batches through the same `carve_many`, so on the
same driver the maps come out bit for bit as the run that wrote the log."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dentdemo import log, outputs
from dentdemo.app.wear import Carved, GrooveTool, GrooveTools, press_of
from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody, Press
from dentdemo.errors import DentdemoError
from dentdemo.model import hitlog, shapes
from dentdemo.model.hitlog import Body, Event, Groove, Hit, HitLogError, Record
from dentdemo.model.scene import BodySpec
from dentdemo.model.validate import read_input

if TYPE_CHECKING:
    from dentdemo.app.simulation import CarveRequest, SimBody, Simulation

#: Largest hit log read, bytes (about five million hits in the binary form).
MAX_LOG_BYTES = 1 << 30


def body_spec(body: SimBody, added: bool) -> dict[str, Any]:
    """What a replay needs to find the body in the scene (its map's side and depth bound) or,
    for a body the scene lacks, to make it (shape, material, map density...; JSON-ready)."""
    spec = body.spec
    kept = {
        "added": added,
        "map_size": body.maps.size[0],
        "max_dent_depth": body.maps.max_dent_depth,
    }
    if not added:
        return kept
    return {
        **kept,
        "shape": shapes.as_dict(spec.shape),
        "material": spec.material.name,
        "texels_per_metre": spec.texels_per_metre,
        "dentable": spec.dentable,
        "bump_map": spec.bump_map,
        "bump_height": spec.bump_height,
        "static": spec.static,
        "position": list(spec.position),
        "orientation": list(spec.orientation),
    }


@dataclass
class HitRecorder:
    """Turns a Simulation's carves into records: kept in `records` and, when `sink` is set,
    handed to it as they happen (a file, a pipe to another process). A body is declared by the
    first batch that carves it (a body no hit reaches costs the log nothing); a reset forgets
    the declarations, since the scene's bodies are made anew."""

    sink: Callable[[Record], None] | None = None
    keep: bool = True
    records: list[Record] = field(default_factory=list)
    #: Carves recorded: hits and groove segments.
    hits: int = 0
    _index: dict[str, int] = field(default_factory=dict)
    _next: int = 0
    _batch: int = 0
    #: Frames before the last reset (a reset starts the simulation's count again at 0; the
    #: log's frames never go back).
    _base: int = 0
    _last: int = 0
    _added: set[str] = field(default_factory=set)

    def frame(self, sim: Simulation) -> int:
        """The log's frame number now: the simulation's, counted on across resets."""
        if self._base + sim.stats.frames < self._last:
            self._base = self._last - sim.stats.frames
        self._last = self._base + sim.stats.frames
        return self._last

    def emit(self, record: Record) -> None:
        if self.keep:
            self.records.append(record)
        if self.sink is not None:
            self.sink(record)

    def attach(self, sim: Simulation) -> None:
        """Start recording `sim` as it is now: a replay starts from the same bodies (the
        scene's, with those added since and their maps as they are)."""
        sim.recorders.append(self)
        self._added = set()

    def restart(self, sim: Simulation) -> None:
        """Start a new log from `sim` as it is now (a compact save's checkpoint); the frames
        count on."""
        self.records = []
        self.hits = 0
        self._index.clear()
        self._added = set()
        self._batch = 0

    def resume(self, records: Sequence[Record]) -> None:
        """Go on from `records` (a loaded log, replayed): the same declarations and numbering."""
        self.records = list(records)
        self.hits = sum(isinstance(r, Hit | Groove) for r in records)
        self._index.clear()
        self._added = set()
        self._batch = 0
        for record in records:
            self._last = max(self._last, record.frame)
            if isinstance(record, Body):
                self._index[record.id] = record.index
                self._next = max(self._next, record.index + 1)
                if record.spec.get("added"):
                    self._added.add(record.id)
            elif isinstance(record, Hit | Groove):
                self._batch = record.batch + 1
            elif record.kind == "reset":
                self._index.clear()
                self._added.clear()

    def added(self, body_id: str) -> None:
        """`body_id` was added while running (the scene file lacks it)."""
        self._added.add(body_id)

    def _declare(self, sim: Simulation, body_id: str) -> int:
        index = self._index.get(body_id)
        if index is not None:
            return index
        if self._next >= hitlog.MAX_BODIES:
            raise DentdemoError(f"hit log: more than {hitlog.MAX_BODIES} bodies")
        body = sim.bodies[body_id]
        spec = body_spec(body, body_id in self._added)
        self.emit(Body(self.frame(sim), self._next, body_id, spec))
        self._index[body_id] = self._next
        self._next += 1
        return self._next - 1

    def batch(
        self,
        sim: Simulation,
        requests: Sequence[CarveRequest],
        grooves: Sequence[Carved] = (),
    ) -> None:
        """One carved batch: a hit record per request, then a groove record per scratch
        segment (app/wear.py), in the batch's order."""
        frame = self.frame(sim)
        for request in requests:  # every body of the batch declared before its first hit
            self._declare(sim, request.impact.body_a)
            self._declare(sim, request.impact.body_b)
        for carved in grooves:
            self._declare(sim, carved.worn)
        for request in requests:
            impact = request.impact
            self.emit(
                Hit(
                    frame,
                    self._batch,
                    self._index[impact.body_a],
                    self._index[impact.body_b],
                    hitlog.rigid_pose(request.model_a, impact.pose_a[1]),
                    hitlog.rigid_pose(request.model_b, impact.pose_b[1]),
                    _vec3(impact.point),
                    _vec3(-impact.normal),
                    float(request.depth_a),
                    float(request.depth_b),
                )
            )
        for carved in grooves:
            tool = carved.tool
            self.emit(
                Groove(
                    frame,
                    self._batch,
                    self._index[carved.worn],
                    tool.radius,
                    tool.length,
                    () if tool.points is None else tuple(float(x) for x in tool.points.ravel()),
                    hitlog.matrix_pose(carved.model),
                    hitlog.matrix_pose(carved.tool_model),
                    _vec3(carved.contact.point),
                    _vec3(carved.contact.direction),
                    float(carved.depth),
                )
            )
        self.hits += len(requests) + len(grooves)
        self._batch += 1

    def stop(self, sim: Simulation, why: str) -> None:
        """Record nothing more of `sim`, with one warning saying from which frame and why."""
        sim.recorders.remove(self)
        log.warn(f"dentdemo: the hit log stops at frame {self.frame(sim)}: {why}")

    def event(self, sim: Simulation, kind: str, body_id: str = "", value: float = 0.0) -> None:
        """An undo, reset, or a declared body's repair or new depth bound (a body not yet
        declared is declared with its bound when a hit first carves it, and a repair of a
        body no logged hit carved changes nothing the log holds)."""
        index = self._index.get(body_id, -1) if body_id else -1
        if body_id and index < 0:
            return
        self.emit(Event(self.frame(sim), kind, index, value))
        if kind == "reset":
            self._index.clear()
            self._added.clear()


def _vec3(v: Iterable[Any]) -> tuple[float, float, float]:
    x, y, z = (float(c) for c in v)
    return (x, y, z)


def _quat(v: Iterable[Any]) -> tuple[float, float, float, float]:
    w, x, y, z = (float(c) for c in v)
    return (w, x, y, z)


# -- files -------------------------------------------------------------------------------------
def check_log_path(flag: str, path: Path) -> Path:
    """A hit log to write: .ddhl (binary) or .jsonl (JSON Lines); checked before any work."""
    if path.suffix.lower() not in (hitlog.BINARY_SUFFIX, hitlog.TEXT_SUFFIX):
        raise DentdemoError(
            f"{flag}: '{path}' must end in {hitlog.BINARY_SUFFIX} (binary) "
            f"or {hitlog.TEXT_SUFFIX} (JSON Lines)"
        )
    return outputs.check_output_file(flag, path)


def log_bytes(path: Path, records: Iterable[Record]) -> bytes:
    if path.suffix.lower() == hitlog.TEXT_SUFFIX:
        return hitlog.to_lines(records).encode()
    return hitlog.to_bytes(records)


def write_log(path: Path, records: Iterable[Record]) -> Path:
    return outputs.write_bytes(path, log_bytes(path, records))


def read_log(flag: str, path: Path) -> tuple[list[Record], list[str]]:
    """A log file's records, checked whole, and where each is in the file; one DentdemoError
    line for any fault."""
    try:
        data = read_input(path, MAX_LOG_BYTES)  # a regular file, bounded: never blocks
        return hitlog.parse_placed(data, f"{flag}: '{path}'")
    except OSError as exc:
        raise DentdemoError(f"{flag}: cannot read '{path}': {exc.strerror or exc}") from None
    except HitLogError as exc:
        raise DentdemoError(str(exc)) from None


# -- replay ------------------------------------------------------------------------------------
def _added_spec(sim: Simulation, record: Body, where: str) -> BodySpec:
    s = record.spec
    try:
        return BodySpec(
            id=record.id,
            shape=shapes.from_dict(s["shape"]),
            material=sim.materials.get(str(s["material"]), where, "key 'material'"),
            position=_vec3(s["position"]),
            orientation=_quat(s["orientation"]),
            static=bool(s["static"]),
            texels_per_metre=float(s["texels_per_metre"]),
            dentable=bool(s["dentable"]),
            bump_map=str(s["bump_map"]),
            bump_height=float(s["bump_height"]),
        )
    except DentdemoError:
        raise
    except (KeyError, TypeError, ValueError) as exc:
        raise DentdemoError(f"{where}: body '{record.id}' has a bad spec ({exc})") from None


class _Bodies:
    """A log's body records against the scene, in order: a scene body the scene lacks (or whose
    maps are another size), or an added body whose id is taken or whose spec does not build, is
    one line naming the record."""

    def __init__(self, sim: Simulation, present: set[str] | None = None) -> None:
        self.sim = sim
        self.scene = {spec.id for spec in sim.scene.bodies}
        self.live = set(sim.bodies)  # what the log starts from
        #: Bodies the log adds that are there already (a compact state's, added in order).
        self.present = present or set()

    def see(self, record: Record, at: str) -> None:
        if isinstance(record, Event) and record.kind == "reset":
            self.live = set(self.scene)
        if not isinstance(record, Body):
            return
        if record.spec.get("added"):
            if record.id in self.present:
                return
            if record.id in self.live:
                raise DentdemoError(f"{at}: added body '{record.id}' is already in the scene")
            _added_spec(self.sim, record, at)
            self.live.add(record.id)
            return
        if record.id not in self.live:
            raise DentdemoError(f"{at}: body '{record.id}' is not in the scene")
        body = self.sim.bodies.get(record.id)
        if body is not None and body.maps.size[0] != record.spec.get("map_size"):
            raise DentdemoError(
                f"{at}: body '{record.id}' has {body.maps.size[0]}^2 maps in the scene, "
                f"the log's were {record.spec.get('map_size')}^2"
            )


class Replayer:
    """Records carved onto a Simulation's bodies as they come (a file read whole, or a stream
    from another process), with no physics step: a batch's hits are carved together by
    `carve_many` once the next record shows the batch is whole (or at `finish`); bodies the log
    added are added, and a reset, undo, repair or new depth bound is done where the log has it.
    Each record is checked before anything of it is done."""

    def __init__(self, sim: Simulation, present: set[str] | None = None) -> None:
        self.sim = sim
        self.carved = 0
        self._bodies = _Bodies(sim, present)
        self._ids: dict[int, str] = {}
        self._pending: list[Press] = []
        self._batch = -1
        self._tools: GrooveTools | None = None

    def apply(self, record: Record, at: str) -> None:
        sim = self.sim
        if isinstance(record, Hit | Groove):
            if record.batch != self._batch:
                self._flush()
                self._batch = record.batch
            if isinstance(record, Hit):
                self._pending.append(_press(sim, self._ids, record))
            else:
                self._pending.append(press_of(sim, self._carved(record), self._groove_tools()))
            return
        self._bodies.see(record, at)
        self._flush()
        if isinstance(record, Body):
            if record.spec.get("added") and record.id not in self._bodies.present:
                sim.add_body(_added_spec(sim, record, at))
            self._ids[record.index] = record.id
            sim.bodies[record.id].maps.max_dent_depth = float(record.spec["max_dent_depth"])
        elif record.kind == "undo":
            sim.undo()
        elif record.kind == "repair":
            sim.repair(self._ids[record.body])
        elif record.kind == "reset":
            sim.reset()
        elif record.kind == "depth_bound":
            sim.bodies[self._ids[record.body]].maps.max_dent_depth = record.value

    def finish(self) -> int:
        """Carve the last batch; returns the hits and groove segments carved in all."""
        self._flush()
        return self.carved

    def _flush(self) -> None:
        if self._pending:
            self.sim.carver.carve_many(self._pending)
            self.carved += len(self._pending)
            self._pending = []
            if self._tools is not None:
                self._tools.next_batch()  # the batch's swept boxes are carved

    def _groove_tools(self) -> GrooveTools:
        if self._tools is None:
            self._tools = GrooveTools(self.sim.gl)
        return self._tools

    def _carved(self, g: Groove) -> Carved:
        points = np.array(g.points, dtype=np.float64).reshape(16, 3) if g.points else None
        return Carved(
            self._ids[g.target],
            GrooveTool(g.radius, g.length, points),
            hitlog.pose_matrix(g.target_pose),
            hitlog.pose_matrix(g.tool_pose),
            ContactFrame(np.array(g.point), np.array(g.direction)),
            g.depth,
        )

    def release(self) -> None:
        """The swept tools this replay made."""
        if self._tools is not None:
            self._tools.release()
            self._tools = None


def replay(
    sim: Simulation,
    records: Sequence[Record],
    names: Sequence[str] | None = None,
    present: set[str] | None = None,
) -> int:
    """Carve a whole log's `records` (checked: model.hitlog.check) onto `sim`'s bodies; its
    body records are checked against the scene first, so a bad one carves nothing. Bodies the
    log adds whose ids are in `present` are taken as they are. Returns the hits carved."""
    where = list(names) if names is not None else [f"record {n + 1}" for n in range(len(records))]
    bodies = _Bodies(sim, present)
    for at, record in zip(where, records, strict=True):
        bodies.see(record, at)
    replayer = Replayer(sim, present)
    try:
        for at, record in zip(where, records, strict=True):
            replayer.apply(record, at)
        return replayer.finish()
    finally:
        replayer.release()


def _press(sim: Simulation, ids: dict[int, str], hit: Hit) -> Press:
    target, tool = sim.bodies[ids[hit.target]], sim.bodies[ids[hit.tool]]
    return Press(
        CarveBody(target.gpu_mesh, target.maps, hitlog.pose_matrix(hit.target_pose)),
        CarveBody(tool.gpu_mesh, tool.maps, hitlog.pose_matrix(hit.tool_pose)),
        ContactFrame(np.array(hit.point), np.array(hit.direction)),
        hit.target_depth,
        hit.tool_depth,
    )
