"""Uniform blocks (std140): a block's layout read from its GLSL declaration, values packed into
its bytes, and a stream buffer that holds the blocks of many draws (bound by range, one draw
after another). A pass whose values change every draw (the carve's, one job after another) sets
them with one range bind instead of a GL call per uniform."""

from __future__ import annotations

import functools
import re
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import moderngl

from dentdemo.gl.shaders import shaders_dir

#: (bytes, alignment, struct format of its values) of each member type std140 lays out here; a
#: mat3 is three columns of a vec4's stride, a bool four bytes (GL reads any non-zero as true).
_TYPES: dict[str, tuple[int, int, str]] = {
    "float": (4, 4, "f"),
    "int": (4, 4, "i"),
    "bool": (4, 4, "I"),
    "vec2": (8, 8, "2f"),
    "ivec2": (8, 8, "2i"),
    "vec3": (12, 16, "3f"),
    "vec4": (16, 16, "4f"),
    "mat3": (48, 16, "12s4x12s4x12s4x"),
    "mat4": (64, 16, "64s"),
}
_BLOCK = re.compile(r"layout\s*\(\s*std140\s*\)\s*uniform\s+(\w+)\s*\{(.*?)\}\s*;", re.S)
_MEMBER = re.compile(r"^\s*(\w+)\s+(\w+)\s*;", re.M)


@dataclass(frozen=True)
class BlockLayout:
    """A std140 uniform block: its name, size (bytes, a multiple of 16) and members in order,
    each (name, type, byte offset)."""

    name: str
    size: int
    members: tuple[tuple[str, str, int], ...]

    @classmethod
    def parse(cls, source: str) -> BlockLayout:
        """The first `layout(std140) uniform Name { type name; ... };` of a GLSL source (no
        arrays, structs or several names a line)."""
        found = _BLOCK.search(re.sub(r"//[^\n]*", "", source))
        if found is None:
            raise ValueError("no std140 uniform block in the source")
        offset, members = 0, []
        for kind, name in _MEMBER.findall(found.group(2)):
            if kind not in _TYPES:
                raise ValueError(f"uniform block {found.group(1)}: member type {kind!r}")
            size, align, _ = _TYPES[kind]
            offset = -(-offset // align) * align
            members.append((name, kind, offset))
            offset += size
        return cls(found.group(1), -(-offset // 16) * 16, tuple(members))

    @classmethod
    def of_file(cls, name: str) -> BlockLayout:
        """The block declared in `name` under shaders/."""
        return cls.parse((shaders_dir() / name).read_text(encoding="utf-8"))

    def names(self) -> frozenset[str]:
        return frozenset(name for name, _, _ in self.members)


@functools.cache
def packer(layout: BlockLayout) -> _Packer:
    """The packer of `layout` (made once)."""
    return _Packer(layout)


class _Packer:
    """Packs a block's bytes from mappings of member values (later ones win; members none
    names are zero): floats, ints and bools as themselves, vectors as sequences, matrices as
    their float32 column-major bytes (what `set_uniform` takes: 64 for a mat4, 36 for a mat3)."""

    def __init__(self, layout: BlockLayout) -> None:
        self.layout = layout
        fmt, end = "<", 0
        for _, kind, offset in layout.members:
            fmt += f"{offset - end}x" + _TYPES[kind][2]
            end = offset + _TYPES[kind][0]
        self._struct = struct.Struct(fmt + f"{layout.size - end}x")
        self._members = [(name, kind) for name, kind, _ in layout.members]
        zero = {"float": (0.0,), "int": (0,), "bool": (0,), "mat3": (b"\0" * 12,) * 3}
        zero |= {"vec2": (0.0,) * 2, "ivec2": (0,) * 2, "vec3": (0.0,) * 3, "vec4": (0.0,) * 4}
        self._zero = zero | {"mat4": (b"\0" * 64,)}

    def pack(self, parts: Sequence[Mapping[str, object]]) -> bytes:
        values: list[object] = []
        for name, kind in self._members:
            value = _UNSET
            for part in parts:
                value = part.get(name, value)
            if value is _UNSET:
                values += self._zero[kind]
            elif kind == "bool":
                values.append(1 if value else 0)
            elif kind in ("float", "int", "mat4"):
                values.append(value)
            elif kind == "mat3":
                m = value
                if not isinstance(m, bytes) or len(m) != 36:
                    raise TypeError(f"{name}: a mat3 as 36 bytes, column-major float32")
                values += (m[0:12], m[12:24], m[24:36])
            else:
                values += value  # type: ignore[arg-type]  # a vector: a sequence
        return self._struct.pack(*values)


_UNSET = object()


class BlockStream:
    """One uniform buffer that blocks are appended to, each at the context's offset alignment,
    and bound by range for the draws that use it; a block that no longer fits starts the buffer
    over with fresh storage (orphaning: once per `capacity` bytes, not once a draw)."""

    def __init__(self, ctx: moderngl.Context, capacity: int = 1 << 18) -> None:
        self.capacity = capacity
        self.buffer = ctx.buffer(reserve=capacity, dynamic=True)
        self.align = max(int(ctx.info.get("GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT", 256)), 16)
        self._end = 0
        #: The parts last placed and where (the same parts again are not written again).
        self._last: tuple[tuple[object, ...], int] | None = None

    def place(self, packer: _Packer, parts: tuple[Mapping[str, object], ...]) -> int:
        """Write the block of `parts` (`_Packer.pack`) unless it is the one written last (the
        same mapping objects: they are not changed once given), and return its offset."""
        last = self._last
        if last is not None and len(last[0]) == len(parts) + 1 and last[0][0] is packer:
            if all(a is b for a, b in zip(last[0][1:], parts, strict=True)):
                return last[1]
        data = packer.pack(parts)
        offset = -(-self._end // self.align) * self.align
        if offset + len(data) > self.capacity:
            self.buffer.orphan()
            offset = 0
        self.buffer.write(data, offset=offset)
        self._end = offset + len(data)
        self._last = ((packer, *parts), offset)
        return offset

    def bind(self, offset: int, size: int, binding: int = 0) -> None:
        self.buffer.bind_to_uniform_block(binding, offset=offset, size=size)

    def release(self) -> None:
        self.buffer.release()
