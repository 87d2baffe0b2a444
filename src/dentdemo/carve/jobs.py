"""A batch's job table: every value the carve's passes take per direction of a hit and per body
they draw (camera, pose, solid, press, clip box and slabs, gather bounds), one std140 entry each
(shaders/carve/job.glsl), written into one uniform buffer once a batch. A draw names its entry
with one integer (`u_job`); the buffer is bound by range, `job_entries` a range (what the driver's
uniform blocks hold), so a draw whose entry lies in another range binds that one.

The entry's layout is read from job.glsl's struct and checked against the driver's own offsets
when each program is built (`check_layout`); carve/params.py holds its members to the parameter
groups the carver fills it from (`ENTRY_GROUPS`), so a member added on one side only is an error
at build time, not a wrong value at draw time."""

from __future__ import annotations

import ctypes
import functools
import re
import struct
from collections.abc import Mapping, Sequence

import moderngl

from dentdemo.carve.constants import JOB_ENTRIES
from dentdemo.errors import ShaderError
from dentdemo.gl.library import gl_library
from dentdemo.gl.shaders import shaders_dir

#: The uniform block that holds the entries, its binding point and its array.
BLOCK, BINDING, ARRAY = "CarveJobs", 0, "u_entries"

#: (bytes, alignment, struct format) of each member type std140 lays out here: a mat3 is three
#: columns of a vec4's stride; a bool four bytes (GL reads any non-zero as true).
_TYPES: dict[str, tuple[int, int, str]] = {
    "float": (4, 4, "f"),
    "int": (4, 4, "i"),
    "bool": (4, 4, "I"),
    "vec2": (8, 8, "2f"),
    "ivec2": (8, 8, "2i"),
    "vec3": (12, 16, "3f"),
    "ivec4": (16, 16, "4i"),
    "mat3": (48, 16, "12s4x12s4x12s4x"),
    "mat4": (64, 16, "64s"),
}
_STRUCT = re.compile(r"struct\s+CarveEntry\s*\{(.*?)\}\s*;", re.S)
_MEMBER = re.compile(r"^\s*(\w+)\s+(\w+)\s*;", re.M)
#: A value of each type where an entry leaves a member unset (it is read by no draw of it).
_ZERO: dict[str, tuple[object, ...]] = {
    "float": (0.0,),
    "int": (0,),
    "bool": (0,),
    "vec2": (0.0, 0.0),
    "ivec2": (0, 0),
    "vec3": (0.0, 0.0, 0.0),
    "ivec4": (0, 0, 0, 0),
    "mat3": (b"\0" * 12,) * 3,
    "mat4": (b"\0" * 64,),
}


class EntryLayout:
    """job.glsl's `CarveEntry`: members (uniform name as the passes read it, GLSL type, byte
    offset) in order, and the array's stride (bytes, a multiple of 16)."""

    def __init__(self, source: str) -> None:
        found = _STRUCT.search(re.sub(r"//[^\n]*", "", source))
        if found is None:
            raise ShaderError("carve/job.glsl: no struct CarveEntry")
        offset, members = 0, []
        for kind, name in _MEMBER.findall(found.group(1)):
            if kind not in _TYPES:
                raise ShaderError(f"carve/job.glsl: CarveEntry.{name} has type {kind!r}")
            size, align, _ = _TYPES[kind]
            offset = -(-offset // align) * align
            members.append((f"u_{name}", kind, offset))
            offset += size
        self.members: tuple[tuple[str, str, int], ...] = tuple(members)
        self.stride = -(-offset // 16) * 16
        fmt, end = "<", 0
        for _, kind, at in members:
            fmt += f"{at - end}x" + _TYPES[kind][2]
            end = at + _TYPES[kind][0]
        self._struct = struct.Struct(fmt + f"{self.stride - end}x")

    def names(self) -> frozenset[str]:
        return frozenset(name for name, _, _ in self.members)

    def pack(self, values: Mapping[str, object]) -> bytes:
        """One entry's bytes from uniform values by name (as the parameter groups give them:
        vectors as sequences, matrices as float32 column-major bytes, 64 for a mat4 and 36 for
        a mat3); members it does not name are zero."""
        flat: list[object] = []
        for name, kind, _ in self.members:
            value = values.get(name)
            if value is None:
                flat += _ZERO[kind]
            elif kind == "mat3":
                if not isinstance(value, bytes) or len(value) != 36:
                    raise TypeError(f"{name}: a mat3 as 36 bytes, column-major float32")
                flat += (value[0:12], value[12:24], value[24:36])
            elif kind in ("vec2", "ivec2", "vec3", "ivec4"):
                flat += value  # type: ignore[arg-type]  # a vector: a sequence
            elif kind == "bool":
                flat.append(1 if value else 0)
            else:
                flat.append(value)
        return self._struct.pack(*flat)


@functools.cache
def entry_layout() -> EntryLayout:
    """The entry of shaders/carve/job.glsl."""
    return EntryLayout((shaders_dir() / "carve/job.glsl").read_text(encoding="utf-8"))


_GL_UNIFORM_OFFSET = 0x8A3B
_GL_INVALID_INDEX = 0xFFFFFFFF


def check_layout(prog: moderngl.Program, where: str) -> None:
    """Hold a program that reads the job table to `entry_layout()`: each member's offset and the
    array's stride as the driver laid them out (std140 makes every member active), else
    ShaderError naming `where`. One query a program, when it is built."""
    layout = entry_layout()
    names = [f"{ARRAY}[0].{name[2:]}" for name, _, _ in layout.members] + [f"{ARRAY}[1].model"]
    gl = gl_library()
    c_names = (ctypes.c_char_p * len(names))(*(n.encode() for n in names))
    indices = (ctypes.c_uint * len(names))()
    gl.glGetUniformIndices(prog.glo, len(names), c_names, indices)
    if any(i == _GL_INVALID_INDEX for i in indices):
        missing = [n for n, i in zip(names, indices, strict=True) if i == _GL_INVALID_INDEX]
        raise ShaderError(f"{where}: the job table has no {missing[0]!r}")
    offsets = (ctypes.c_int * len(names))()
    gl.glGetActiveUniformsiv(prog.glo, len(names), indices, _GL_UNIFORM_OFFSET, offsets)
    ours = [at for _, _, at in layout.members] + [layout.stride]
    for name, theirs, mine in zip(names, offsets, ours, strict=True):
        if theirs != mine:
            raise ShaderError(f"{where}: {name} lies at byte {theirs}, carve/jobs.py packs {mine}")
    block = prog[BLOCK]
    if isinstance(block, moderngl.UniformBlock):
        block.binding = BINDING


class RangeTable:
    """A uniform buffer of a batch's entries of one size, bound by range at `binding`, at most
    `per_range` entries a range (each range's start aligned as the driver asks): `write` them
    all at once (fresh storage each time, so no queued draw that reads the last batch's makes
    the driver wait), then `use` an entry before each draw that reads it: it binds the entry's
    range when another is bound and gives the index within it."""

    def __init__(
        self, ctx: moderngl.Context, binding: int, entry_bytes: int, per_range: int
    ) -> None:
        align = max(int(ctx.info.get("GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT", 256)), 16)
        self._binding, self._per_range = binding, per_range
        #: Bytes of one range, and from one range's start to the next's (aligned).
        self._range = per_range * entry_bytes
        self._step = -(-self._range // align) * align
        self.buffer = ctx.buffer(reserve=self._step)
        self._bound = -1  # the range bound at `binding` since `write`, or -1

    def write_packed(self, entries: Sequence[bytes]) -> None:
        """Every entry of a batch, packed, in order (entry k is `use(k)`'s). The storage holds
        whole ranges; what follows the last entry is not written (no draw reads it)."""
        per = self._per_range
        parts = [b"".join(entries[at : at + per]) for at in range(0, max(len(entries), 1), per)]
        data = b"".join(part + b"\0" * (self._step - len(part)) for part in parts[:-1])
        data += parts[-1]
        self.buffer.orphan(max(len(parts) * self._step, self.buffer.size))
        if data:
            self.buffer.write(data)
        self._bound = -1

    def use(self, entry: int) -> int:
        """Bind the range that holds `entry` (unless bound) and return its index there."""
        chunk, index = divmod(entry, self._per_range)
        if chunk != self._bound:
            self.buffer.bind_to_uniform_block(
                self._binding, offset=chunk * self._step, size=self._range
            )
            self._bound = chunk
        return index

    def forget(self) -> None:
        """Another buffer may be bound at the binding now (the host's, given back)."""
        self._bound = -1

    def release(self) -> None:
        self.buffer.release()


#: The largest uniform block a range of the job table may fill, bytes (what GL drivers commonly
#: allow; GL 3.3 guarantees 16 KiB, `JOB_ENTRIES`).
MAX_RANGE_BYTES = 1 << 16


def job_entries(ctx: moderngl.Context) -> int:
    """Entries a range of the job table holds in `ctx`: as many as its uniform blocks hold
    (GL_MAX_UNIFORM_BLOCK_SIZE, up to MAX_RANGE_BYTES), at least `JOB_ENTRIES`. The carve's
    programs are built with it (job.glsl's array), so that a batch spans few ranges: each draw
    is instanced over entries of one range, and each range a pass reaches is bound once."""
    size = min(int(ctx.info.get("GL_MAX_UNIFORM_BLOCK_SIZE", 0)), MAX_RANGE_BYTES)
    return max(JOB_ENTRIES, size // entry_layout().stride)


class JobTable(RangeTable):
    """A batch's job table: `job_entries` entries (`entry_layout`) a range at BINDING; `use`
    gives the index for `u_job`."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.per_range = job_entries(ctx)
        super().__init__(ctx, BINDING, entry_layout().stride, self.per_range)

    def write(self, entries: Sequence[Mapping[str, object]]) -> None:
        """Every entry of a batch, by uniform name, in order (entry k is `use(k)`'s)."""
        layout = entry_layout()
        self.write_packed([layout.pack(entry) for entry in entries])


#: The texel rectangles' table (util/rect.vert, RECT_TABLE 1): its block and binding, and the
#: rectangles a range holds (two ivec4 each: GL 3.3's smallest uniform block holds 512).
RECT_BLOCK, RECT_BINDING, RECT_ENTRIES = "CarveRects", 1, 512
_RECT = struct.Struct("<4i4i")


class RectTable(RangeTable):
    """A batch's texel rectangles (passes 4 and 5's RECT draws, instanced): each its texels
    (x, y, width, height) and its job's entry within the job table's range its draw binds."""

    def __init__(self, ctx: moderngl.Context) -> None:
        super().__init__(ctx, RECT_BINDING, _RECT.size, RECT_ENTRIES)

    def write(self, rects: Sequence[tuple[int, int, int, int, int]]) -> None:
        self.write_packed([_RECT.pack(*rect, 0, 0, 0) for rect in rects])


def job_table(gl_cache: dict, ctx: moderngl.Context) -> JobTable:
    """The context's job table (one, shared by its carvers and the map-wide normal rebuild:
    each writes its entries before it draws)."""
    key = "carve:job-table"
    if key not in gl_cache:
        gl_cache[key] = JobTable(ctx)
    return gl_cache[key]
