"""The hit log: every carve as a record of the few numbers that decide it, so the maps can be
rebuilt anywhere from the scene and the log (docs/design.md, "Damage as data").

Two encodings of the same records:

- JSON Lines (`.jsonl`), one object a line, for people. Floats are written with Python's
  shortest round-trip form, so a record read back is the same float64s bit for bit.
- A compact binary form (`.ddhl`) for programs: a header (magic, version, the schema as JSON),
  then records of a kind byte and a little-endian payload (`SCHEMA`). A hit is 6 float64
  vectors and its two depths (182 bytes), less a rotation that is exactly the identity and a
  depth that is exactly 0; a batch record gives the frame of the hits after it.

Units: metres, world frame. A pose (at first touch, exactly as the carve used it) is 7 numbers,
the body's origin (m) and its rotation as a unit quaternion (w, x, y, z), as the simulation's
rigid bodies have it; or 12, the rows of the top 3 x 4 of a world-from-local matrix, as a host
program's surfaces (which may be scaled) have it. Bodies are named
by an index that a body record declares once; an index is never reused within a log.

Pure data: nothing here reads or writes files (app/hitlog.py does)."""

from __future__ import annotations

import functools
import json
import math
import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dentdemo.model.pose import pose_matrix as _rigid_matrix

MAGIC = b"DDHL"
VERSION = 1
#: The binary form's suffix, and the JSON Lines form's.
BINARY_SUFFIX = ".ddhl"
TEXT_SUFFIX = ".jsonl"

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
#: 7 numbers (origin, quaternion w x y z) or 12 (a 3 x 4 matrix, rows).
Pose = tuple[float, ...]


@dataclass(frozen=True)
class Body:
    """A body the log's records name: `index` (0..65535, declared once), its id in the
    simulation, and its spec (shape as `model.shapes.as_dict`, material by name, map density,
    `max_dent_depth` in metres, and `added`: True for a body the scene file lacks, made while
    running, which a replay adds from this spec)."""

    frame: int
    index: int
    id: str
    spec: dict[str, Any]


@dataclass(frozen=True)
class Hit:
    """One carve of one hit: `target` pressed by `tool` along `direction` (world, non-zero) at
    `point` (world metres), the target dented `target_depth` and the tool `tool_depth` (metres).
    Poses at first touch. Hits of one `batch` were carved together (one `carve_many`)."""

    frame: int
    batch: int
    target: int
    tool: int
    target_pose: Pose
    tool_pose: Pose
    point: Vec3
    direction: Vec3
    target_depth: float
    tool_depth: float


@dataclass(frozen=True)
class Groove:
    """One segment of a scratch (app/wear.py): `target` pressed `depth` metres along
    `direction` at `point` by a swept tool, carved in `batch` with its hits. The tool is a
    sphere of `radius` swept along `length` (a capsule, posed `tool_pose`) or, where `points`
    is given, the hull of a box's corners at both ends of the segment (16 x 3 numbers, the
    target's frame, metres; posed as the target)."""

    frame: int
    batch: int
    target: int
    radius: float
    length: float
    points: tuple[float, ...]
    target_pose: Pose
    tool_pose: Pose
    point: Vec3
    direction: Vec3
    depth: float


@dataclass(frozen=True)
class Event:
    """Something other than a hit that changes the maps: `undo` (the last batch taken back),
    `repair` (`body` back to pristine), `reset` (every body back to the scene), or `depth_bound`
    (`body`'s `max_dent_depth` became `value` metres: a materials reload)."""

    frame: int
    kind: str
    body: int = -1
    value: float = 0.0


Record = Body | Hit | Groove | Event

EVENT_KINDS = ("undo", "repair", "reset", "depth_bound")
_KIND_BODY, _KIND_BATCH, _KIND_HIT = 1, 2, 3
_KIND_EVENT = {name: 4 + i for i, name in enumerate(EVENT_KINDS)}
_KIND_GROOVE = 9
_GROOVE = struct.Struct("<BH")  # flags (1: a box's hull), target; then float64s
_KIND_END = 15
_END = struct.Struct("<I")  # how many records came before it
_EVENT_OF = {code: name for name, code in _KIND_EVENT.items()}
_BODY = struct.Struct("<IHBIdB")  # frame, index, flags (1: added), map side, depth bound, id bytes
_BATCH = struct.Struct("<I")  # frame
_HIT = struct.Struct("<BHH")  # flags, target, tool; then the float64s the flags do not elide
_EVENT = struct.Struct("<IHd")  # frame, body (0xFFFF: none), value
_F64 = struct.Struct("<d")
_U16 = struct.Struct("<H")
#: Hit flags: what is left out because it is exactly this value.
_SAME_TARGET_ROTATION, _SAME_TOOL_ROTATION, _NO_TARGET_DEPTH, _NO_TOOL_DEPTH = 1, 2, 4, 8
_TARGET_MATRIX, _TOOL_MATRIX = 16, 32
IDENTITY: Quat = (1.0, 0.0, 0.0, 0.0)
_NO_BODY = 0xFFFF
#: At most this many bodies a log (the binary form's 16-bit index).
MAX_BODIES = _NO_BODY

SCHEMA: dict[str, Any] = {
    "order": "little-endian; header: 'DDHL' u16 version u16 n, n bytes of this JSON",
    "1 body": "u32 frame u16 index u8 flags(1 added) u32 map_side f64 max_dent_depth u8 n id"
    " [added: u16 m, m bytes JSON spec]",
    "2 batch": "u32 frame; the hits after it are one batch, numbered from 0",
    "3 hit": "u8 flags u16 target u16 tool f64 target_pose tool_pose point[3] direction[3]"
    " target_depth tool_depth; a pose is origin[3] quaternion[4], or with flags 16|32 a 3x4"
    " matrix[12] (rows); flags 1|2: a quaternion left out, it is (1,0,0,0); 4|8: a depth left"
    " out, it is 0",
    "4-7 undo repair reset depth_bound": "u32 frame u16 body(65535 none) f64 value",
    "9 groove": "u8 flags(1 hull) u16 target f64 radius length [hull: points[48]]"
    " target_pose[12] tool_pose[12] point[3] direction[3] depth; in the batch of the hits"
    " before it",
    "15 end": "u32 records before it; a file's last record (a stream may lack it)",
    "units": "metres, world frame, quaternions w x y z",
}


def pose_matrix(pose: Pose) -> NDArray[np.float64]:
    """A record's pose as the world-from-local 4x4 the carve was given: built by the same
    function from the same float64s, so bit for bit the same matrix."""
    if len(pose) == 12:
        m = np.eye(4)
        m[:3, :] = np.array(pose, dtype=np.float64).reshape(3, 4)
        return m
    return _rigid_matrix(pose[:3], pose[3:])


def rigid_pose(model: NDArray[np.float64], quaternion: Any) -> Pose:
    """A rigid body's pose record: `model`'s origin (m) and the quaternion it was built from."""
    return (*(float(c) for c in model[:3, 3]), *(float(c) for c in quaternion))


def matrix_pose(model: NDArray[np.float64]) -> Pose:
    """Any affine pose's record: the top 3 x 4 of `model`, rows."""
    return tuple(float(c) for c in np.asarray(model, dtype=np.float64)[:3, :].ravel())


class HitLogError(ValueError):
    """A log that fails its check; the message names the record's line or byte offset."""


# -- checks ------------------------------------------------------------------------------------
def _finite(where: str, name: str, values: Iterable[float]) -> None:
    for v in values:
        if not math.isfinite(v):
            raise HitLogError(f"{where}: {name} is not finite ({v})")


class Checker:
    """The log's rules, record by record (a file or a stream): bodies declared once and before
    any record names them, frames and batches never going back, a batch's hits contiguous and
    in one frame, finite numbers, unit quaternions, non-zero directions, depths >= 0."""

    def __init__(self) -> None:
        self.declared: set[int] = set()
        self.frame = self.batch = self.batch_frame = -1
        self.closed: set[int] = set()  # batches that another record has followed

    def add(self, record: Record, at: str) -> Record:
        """`record`, or a HitLogError naming `at` (its line or offset)."""
        if record.frame < self.frame:
            raise HitLogError(f"{at}: frame {record.frame} comes after frame {self.frame}")
        self.frame = record.frame
        if isinstance(record, Body):
            if record.index in self.declared or not 0 <= record.index < MAX_BODIES:
                raise HitLogError(f"{at}: body index {record.index} declared twice or out of range")
            self.declared.add(record.index)
        elif isinstance(record, Hit | Groove):
            self._carve(record, at)
        else:
            if record.kind not in EVENT_KINDS:
                raise HitLogError(f"{at}: unknown record kind '{record.kind}'")
            if record.kind in ("repair", "depth_bound") and record.body not in self.declared:
                raise HitLogError(f"{at}: body {record.body} names no body declared before it")
            _finite(at, "value", [record.value])
            if record.kind == "depth_bound" and record.value <= 0:
                raise HitLogError(f"{at}: depth bound must be > 0, got {record.value}")
        if not isinstance(record, Hit) and self.batch >= 0:
            self.closed.add(self.batch)
        return record

    def _carve(self, record: Hit | Groove, at: str) -> None:
        named = [("target", record.target)]
        if isinstance(record, Hit):
            named.append(("tool", record.tool))
        for name, index in named:
            if index not in self.declared:
                raise HitLogError(f"{at}: {name} {index} names no body declared before it")
        if record.batch != self.batch:
            if record.batch < self.batch or record.batch in self.closed:
                raise HitLogError(f"{at}: batch {record.batch} is out of order")
            self.closed.add(self.batch)
            self.batch, self.batch_frame = record.batch, record.frame
        elif record.frame != self.batch_frame:
            raise HitLogError(
                f"{at}: batch {self.batch} spans frames {self.batch_frame} and {record.frame}"
            )
        _finite(at, "a number", _numbers(record))
        if isinstance(record, Groove):
            if len(record.points) not in (0, 48) or len(record.target_pose) != 12:
                raise HitLogError(f"{at}: a groove has 0 or 48 point numbers and 12-number poses")
            if record.depth < 0 or record.radius < 0 or record.length < 0:
                raise HitLogError(f"{at}: a groove's depth and sizes are >= 0")
        if not math.sqrt(sum(x * x for x in record.direction)) > 1e-12:
            raise HitLogError(f"{at}: direction is zero")
        for name, pose in (("target pose", record.target_pose), ("tool pose", record.tool_pose)):
            if len(pose) not in (7, 12):
                raise HitLogError(f"{at}: {name} has {len(pose)} numbers, not 7 or 12")
            norm = math.sqrt(sum(x * x for x in pose[3:]))
            if len(pose) == 7 and abs(norm - 1.0) > 1e-6:
                raise HitLogError(f"{at}: {name}'s quaternion is not a unit vector ({norm:g})")
        if isinstance(record, Hit) and (record.target_depth < 0 or record.tool_depth < 0):
            raise HitLogError(f"{at}: a depth is negative")


def check(records: Iterable[Record], where: Iterable[str] | None = None) -> list[Record]:
    """Every record checked (`Checker`), in order; returns them, or raises HitLogError naming the
    first bad one (`where` names each record: its line or offset)."""
    checker = Checker()
    names = iter(where) if where is not None else None
    return [
        checker.add(record, next(names) if names is not None else f"record {n + 1}")
        for n, record in enumerate(records)
    ]


def _numbers(record: Hit | Groove) -> tuple[float, ...]:
    if isinstance(record, Groove):
        g = record
        return (
            g.radius,
            g.length,
            *g.points,
            *g.target_pose,
            *g.tool_pose,
            *g.point,
            *g.direction,
            g.depth,
        )
    return _hit_numbers(record)


def _hit_numbers(h: Hit) -> tuple[float, ...]:
    return (
        *h.target_pose,
        *h.tool_pose,
        *h.point,
        *h.direction,
        h.target_depth,
        h.tool_depth,
    )


# -- binary ------------------------------------------------------------------------------------
def header() -> bytes:
    schema = json.dumps(SCHEMA, separators=(",", ":")).encode()
    return MAGIC + struct.pack("<HH", VERSION, len(schema)) + schema


class Encoder:
    """Records to the binary form, one at a time (a file or a stream): a hit of a new batch is
    preceded by a batch record."""

    def __init__(self) -> None:
        self._batch = -1

    def encode(self, record: Record) -> bytes:
        if isinstance(record, Hit):
            return self._hit(record)
        if isinstance(record, Groove):
            head = self._batch_of(record)
            values = _numbers(record)
            flags = 1 if record.points else 0
            packed = struct.pack(f"<{len(values)}d", *values)
            return head + bytes([_KIND_GROOVE]) + _GROOVE.pack(flags, record.target) + packed
        if isinstance(record, Body):
            name = record.id.encode()
            added = bool(record.spec.get("added"))
            out = bytes([_KIND_BODY]) + _BODY.pack(
                record.frame,
                record.index,
                int(added),
                int(record.spec["map_size"]),
                float(record.spec["max_dent_depth"]),
                len(name),
            )
            out += name
            if added:
                text = json.dumps(record.spec, separators=(",", ":")).encode()
                out += _U16.pack(len(text)) + text
            return out
        body = _NO_BODY if record.body < 0 else record.body
        return bytes([_KIND_EVENT[record.kind]]) + _EVENT.pack(record.frame, body, record.value)

    def _batch_of(self, record: Hit | Groove) -> bytes:
        """A batch record when `record` starts a new batch, else nothing."""
        if record.batch == self._batch:
            return b""
        self._batch = record.batch
        return bytes([_KIND_BATCH]) + _BATCH.pack(record.frame)

    def _hit(self, h: Hit) -> bytes:
        out = self._batch_of(h)
        flags = (_NO_TARGET_DEPTH if _same((h.target_depth,), (0.0,)) else 0) | (
            _NO_TOOL_DEPTH if _same((h.tool_depth,), (0.0,)) else 0
        )
        values: list[float] = []
        for pose, same, matrix in (
            (h.target_pose, _SAME_TARGET_ROTATION, _TARGET_MATRIX),
            (h.tool_pose, _SAME_TOOL_ROTATION, _TOOL_MATRIX),
        ):
            if len(pose) == 12:
                flags |= matrix
                values += pose
            elif _same(pose[3:], IDENTITY):
                flags |= same
                values += pose[:3]
            else:
                values += pose
        values += [*h.point, *h.direction]
        values += [] if flags & _NO_TARGET_DEPTH else [h.target_depth]
        values += [] if flags & _NO_TOOL_DEPTH else [h.tool_depth]
        packed = struct.pack(f"<{len(values)}d", *values)
        return out + bytes([_KIND_HIT]) + _HIT.pack(flags, h.target, h.tool) + packed


def _same(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    """Equal bit for bit (so -0.0 is not 0.0 and is written out)."""
    return all(_F64.pack(x) == _F64.pack(y) for x, y in zip(a, b, strict=True))


def to_bytes(records: Iterable[Record]) -> bytes:
    """A whole log file: header, records, and the end record that tells a cut file."""
    encoder = Encoder()
    body = [encoder.encode(r) for r in records]
    return header() + b"".join(body) + end(len(body))


def end(count: int) -> bytes:
    """The end record after `count` records (a stream's sender writes it when it is done)."""
    return bytes([_KIND_END]) + _END.pack(count)


class _Reader:
    def __init__(self, data: bytes, offset: int) -> None:
        self.data, self.offset = data, offset

    def take(self, layout: struct.Struct) -> tuple[Any, ...]:
        values = layout.unpack_from(self.data, self.offset)
        self.offset += layout.size
        return values

    def raw(self, n: int) -> bytes:
        if self.offset + n > len(self.data):
            raise struct.error("short")
        self.offset += n
        return self.data[self.offset - n : self.offset]

    def floats(self, n: int) -> tuple[float, ...]:
        return self.take(_doubles(n))


@functools.cache
def _doubles(n: int) -> struct.Struct:
    """`n` little-endian float64s (a handful of counts occur: made once each)."""
    return struct.Struct(f"<{n}d")


def _read_hit(r: _Reader, frame: int, batch: int) -> Hit:
    flags, target, tool = r.take(_HIT)

    def pose(same: int, matrix: int) -> Pose:
        if flags & matrix:
            return r.floats(12)
        return r.floats(3) + (IDENTITY if flags & same else r.floats(4))

    target_pose = pose(_SAME_TARGET_ROTATION, _TARGET_MATRIX)
    tool_pose = pose(_SAME_TOOL_ROTATION, _TOOL_MATRIX)
    point, direction = r.floats(3), r.floats(3)
    target_depth = 0.0 if flags & _NO_TARGET_DEPTH else r.floats(1)[0]
    tool_depth = 0.0 if flags & _NO_TOOL_DEPTH else r.floats(1)[0]
    return Hit(
        frame,
        batch,
        target,
        tool,
        target_pose,
        tool_pose,
        point,  # type: ignore[arg-type]
        direction,  # type: ignore[arg-type]
        target_depth,
        tool_depth,
    )


def _read_groove(r: _Reader, frame: int, batch: int) -> Groove:
    flags, target = r.take(_GROOVE)
    radius, length = r.floats(2)
    points = r.floats(48) if flags & 1 else ()
    target_pose, tool_pose = r.floats(12), r.floats(12)
    point, direction = r.floats(3), r.floats(3)
    (depth,) = r.floats(1)
    return Groove(
        frame,
        batch,
        target,
        radius,
        length,
        points,
        target_pose,
        tool_pose,
        point,  # type: ignore[arg-type]
        direction,  # type: ignore[arg-type]
        depth,
    )


def _read_body(r: _Reader) -> Body:
    frame, index, flags, side, bound, n = r.take(_BODY)
    name = r.raw(n).decode()
    spec: dict[str, Any] = {"added": False}
    if flags & 1:
        (m,) = r.take(_U16)
        spec = dict(json.loads(r.raw(m)))
        if not isinstance(spec, dict):
            raise TypeError("an added body's spec is a JSON object")
    spec.update(added=bool(flags & 1), map_size=side, max_dent_depth=bound)
    return Body(frame, index, name, spec)


class Decoder:
    """The binary form read as it arrives (a pipe, a socket): `feed` takes bytes and returns
    the whole records they complete, each with its offset; `ended` once the end record came.
    A malformed stream raises HitLogError naming the offset."""

    def __init__(self, source: str) -> None:
        self.source = source
        self._buffer = b""
        self._consumed = 0  # stream offset of the buffer's first byte
        self._header = False
        self._frame = self._batch = -1
        self.count = 0
        self.ended = False

    def feed(self, data: bytes) -> list[tuple[str, Record]]:
        self._buffer += data
        out: list[tuple[str, Record]] = []
        if not self._header and not self._read_header():
            return out
        # One pass over the buffer; what is left (a record the stream cut) is kept once, at the
        # end: trimming after each record copied the rest of a whole file each time.
        r = _Reader(self._buffer, 0)
        while r.offset < len(self._buffer) and not self.ended:
            start = r.offset
            at = f"{self.source}: record at offset {self._consumed + start}"
            try:
                record = self._record(r, at)
            except struct.error:
                r.offset = start  # a record cut by the stream: wait for the rest
                break
            except (ValueError, KeyError, TypeError) as exc:
                if isinstance(exc, HitLogError):
                    raise
                raise HitLogError(f"{at}: bad body record ({exc})") from None
            if record is not None:
                out.append((at, record))
        self._buffer = self._buffer[r.offset :]
        self._consumed += r.offset
        if self.ended and self._buffer:
            raise HitLogError(f"{self.source}: bytes after the end record")
        return out

    def _read_header(self) -> bool:
        data = self._buffer
        if len(data) >= 4 and data[:4] != MAGIC:
            raise HitLogError(f"{self.source}: not a dentdemo hit log (no 'DDHL' at offset 0)")
        if len(data) < 8:
            return False
        version, schema_len = struct.unpack_from("<HH", data, 4)
        if version != VERSION:
            raise HitLogError(
                f"{self.source}: version {version}, this dentdemo reads version {VERSION}"
            )
        if len(data) < 8 + schema_len:
            return False
        self._buffer = data[8 + schema_len :]
        self._consumed = 8 + schema_len
        self._header = True
        return True

    def _record(self, r: _Reader, at: str) -> Record | None:
        """The next record (None: a batch record, which only sets the frame and batch)."""
        kind = r.raw(1)[0]
        if kind == _KIND_END:
            (expected,) = r.take(_END)
            if expected != self.count:
                raise HitLogError(f"{at}: the end record counts {expected}, not {self.count}")
            self.ended = True
            return None
        if kind == _KIND_BATCH:
            (self._frame,) = r.take(_BATCH)
            self._batch += 1
            return None
        if kind == _KIND_HIT:
            if self._batch < 0:
                raise HitLogError(f"{at}: a hit before any batch record")
            record: Record = _read_hit(r, self._frame, self._batch)
        elif kind == _KIND_GROOVE:
            if self._batch < 0:
                raise HitLogError(f"{at}: a groove before any batch record")
            record = _read_groove(r, self._frame, self._batch)
        elif kind == _KIND_BODY:
            record = _read_body(r)
        elif kind in _EVENT_OF:
            when, who, value = r.take(_EVENT)
            record = Event(when, _EVENT_OF[kind], -1 if who == _NO_BODY else who, value)
        else:
            raise HitLogError(f"{at}: unknown record kind {kind}")
        self.count += 1
        return record


def _read_binary(data: bytes, source: str) -> list[tuple[str, Record]]:
    decoder = Decoder(source)
    records = decoder.feed(data)
    if not decoder._header:
        raise HitLogError(f"{source}: truncated header")
    if not decoder.ended:
        if decoder._buffer:
            raise HitLogError(f"{source}: record at offset {decoder._consumed}: truncated")
        raise HitLogError(f"{source}: truncated at offset {len(data)} (no end record)")
    return records


# -- JSON Lines --------------------------------------------------------------------------------
def to_json(record: Record) -> dict[str, Any]:
    if isinstance(record, Hit):
        return {"kind": "hit", **{k: _plain(v) for k, v in record.__dict__.items()}}
    if isinstance(record, Groove):
        return {"kind": "groove", **{k: _plain(v) for k, v in record.__dict__.items()}}
    if isinstance(record, Body):
        return {"kind": "body", **record.__dict__}
    return {"kind": record.kind, "frame": record.frame, "body": record.body, "value": record.value}


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


def to_lines(records: Iterable[Record]) -> str:
    """A whole log as JSON Lines, floats in their shortest round-trip form (float64 exact),
    and the end line that tells a cut file."""
    lines = [json.dumps(to_json(r), allow_nan=False) + "\n" for r in records]
    return "".join(lines) + json.dumps({"kind": "end", "records": len(lines)}) + "\n"


def _tuple(fields: dict[str, Any], key: str, n: tuple[int, ...]) -> tuple[float, ...]:
    value = fields[key]
    if not isinstance(value, list) or len(value) not in n:
        raise TypeError(f"'{key}' must be a list of {' or '.join(map(str, n))} numbers")
    return tuple(_number(key, v) for v in value)


def _number(key: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise TypeError(f"'{key}' must be a number, got {v!r}")
    return float(v)


def _integer(fields: dict[str, Any], key: str) -> int:
    v = fields[key]
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < 2**32:
        raise TypeError(f"'{key}' must be an integer in [0, 2^32), got {v!r}")
    return v


def from_json(fields: dict[str, Any]) -> Record:
    kind = fields.get("kind")
    if kind == "hit":
        t = {k: _tuple(fields, k, n) for k, n in _HIT_TUPLES.items()}
        return Hit(
            _integer(fields, "frame"),
            _integer(fields, "batch"),
            _integer(fields, "target"),
            _integer(fields, "tool"),
            t["target_pose"],
            t["tool_pose"],
            t["point"],  # type: ignore[arg-type]
            t["direction"],  # type: ignore[arg-type]
            _number("target_depth", fields["target_depth"]),
            _number("tool_depth", fields["tool_depth"]),
        )
    if kind == "groove":
        g = {k: _tuple(fields, k, n) for k, n in _GROOVE_TUPLES.items()}
        return Groove(
            _integer(fields, "frame"),
            _integer(fields, "batch"),
            _integer(fields, "target"),
            _number("radius", fields["radius"]),
            _number("length", fields["length"]),
            g["points"],
            g["target_pose"],
            g["tool_pose"],
            g["point"],  # type: ignore[arg-type]
            g["direction"],  # type: ignore[arg-type]
            _number("depth", fields["depth"]),
        )
    if kind == "body":
        spec = fields["spec"]
        if not isinstance(spec, dict) or not isinstance(fields["id"], str):
            raise TypeError("a body needs an 'id' string and a 'spec' table")
        return Body(_integer(fields, "frame"), _integer(fields, "index"), fields["id"], spec)
    if kind in EVENT_KINDS:
        body = fields.get("body", -1)
        if isinstance(body, bool) or not isinstance(body, int):
            raise TypeError(f"'body' must be an integer, got {body!r}")
        return Event(_integer(fields, "frame"), kind, body, _number("value", fields["value"]))
    raise TypeError(f"unknown record kind {kind!r}")


_HIT_TUPLES = {"target_pose": (7, 12), "tool_pose": (7, 12), "point": (3,), "direction": (3,)}
_GROOVE_TUPLES = {
    "points": (0, 48),
    "target_pose": (12,),
    "tool_pose": (12,),
    "point": (3,),
    "direction": (3,),
}


def _read_lines(text: str, source: str) -> Iterator[tuple[str, Record]]:
    count = 0
    ended = False
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        at = f"{source}: line {n}"
        if ended:
            raise HitLogError(f"{at}: a record after the end line")
        try:
            fields = json.loads(line, parse_constant=_no_constant)
            if not isinstance(fields, dict):
                raise TypeError("a record is a JSON object")
            if fields.get("kind") == "end":
                if fields.get("records") != count:
                    raise HitLogError(
                        f"{at}: the end line counts {fields.get('records')}"
                        f" records, the log has {count}"
                    )
                ended = True
                continue
            count += 1
            yield at, from_json(fields)
        except (ValueError, KeyError, TypeError) as exc:
            if isinstance(exc, HitLogError):
                raise
            what = f"missing key {exc}" if isinstance(exc, KeyError) else str(exc)
            raise HitLogError(f"{at}: {what}") from None
    if not ended:
        raise HitLogError(f"{source}: truncated after line {n if text else 0} (no end line)")


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} is not a finite number")


def parse(data: bytes, source: str) -> list[Record]:
    """The records of a log in either form (the binary form starts with its magic), checked
    whole (`check`) before any is returned: a bad log gives nothing but one HitLogError naming
    `source` and the record's line or offset."""
    return parse_placed(data, source)[0]


def parse_placed(data: bytes, source: str) -> tuple[list[Record], list[str]]:
    """`parse`, and where each record is (`source: line N` or `source: record at offset N`)."""
    if data[:4] == MAGIC:
        pairs = _read_binary(data, source)
    else:
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise HitLogError(
                f"{source}: neither a binary hit log nor UTF-8 JSON Lines (byte {exc.start})"
            ) from None
        pairs = list(_read_lines(text, source))
    places = [at for at, _ in pairs]
    return check((r for _, r in pairs), places), places
