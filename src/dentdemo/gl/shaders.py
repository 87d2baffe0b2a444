"""Shader loader over `shaders/`: `#version` first, `#include "file"` with a depth limit and cycle
detection, `#line` markers so compile and link errors name the offending file and line.
"""

from __future__ import annotations

import functools
import re
import struct
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import moderngl

from dentdemo.errors import ShaderError
from dentdemo.resources import shaders_dir

MAX_INCLUDE_DEPTH = 16
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')
_VERSION = re.compile(r"^\s*#\s*version\s+\d+")
# Driver messages: Mesa "0:12(5): error: ...", NVIDIA "0(12) : error C0000: ...".
_LOCATION = re.compile(r"\b(\d+)[:(](\d+)\)?")
# Drivers disagree on (and Mesa sometimes drops) the source-string number of `#line N S`, so the
# file is encoded in the line number itself: line = file_index * LINE_STRIDE + line_in_file.
LINE_STRIDE = 100000


@dataclass
class ExpandedSource:
    """A shader's source after includes, with the files that `#line` numbers refer to."""

    text: str
    #: files[i] is the path of source-string number i in the `#line` markers.
    files: list[Path] = field(default_factory=list)

    def describe(self, reported_line: int) -> tuple[str, str]:
        """(file:line, the source line) for a line number reported by the driver."""
        file_index, line = divmod(reported_line, LINE_STRIDE)
        if not 0 <= file_index < len(self.files):
            return f"<source {file_index}>:{line}", ""
        path = self.files[file_index]
        try:
            lines = path.read_text().splitlines()
            text = lines[line - 1].strip() if 0 < line <= len(lines) else ""
        except OSError:
            text = ""
        return f"{_short(path)}:{line}", text


class ShaderLibrary:
    """Loads shader files from a root folder and builds moderngl programs from them."""

    def __init__(self, root: Path | None = None) -> None:
        self.root = Path(root) if root else shaders_dir()

    def expand(self, name: str, defines: dict[str, object] | None = None) -> ExpandedSource:
        """Read `name` (relative to the root) with its includes spliced in and `defines` set as
        `#define NAME VALUE` right after the `#version` line (compile-time variants)."""
        path = self._resolve(name, None)
        out = ExpandedSource(text="")
        lines: list[str] = []
        first = path.read_text().splitlines()
        if not first or not _VERSION.match(first[0]):
            raise ShaderError(f"{_short(path)}:1: a shader must start with '#version 330 core'")
        lines.append(first[0])
        for key, value in sorted((defines or {}).items()):
            if not re.fullmatch(r"[A-Z_][A-Z0-9_]*", key):
                raise ShaderError(f"bad shader define name '{key}'")
            lines.append(f"#define {key} {value}")
        self._splice(path, first, 1, lines, out, stack=[path])
        out.text = "\n".join(lines) + "\n"
        return out

    def _splice(
        self,
        path: Path,
        text_lines: list[str],
        start: int,
        lines: list[str],
        out: ExpandedSource,
        stack: list[Path],
    ) -> None:
        file_id = len(out.files)
        out.files.append(path)
        lines.append(f"#line {file_id * LINE_STRIDE + start + 1}")
        for number, line in enumerate(text_lines[start:], start=start + 1):
            match = _INCLUDE.match(line)
            if not match:
                if _VERSION.match(line):
                    raise ShaderError(
                        f"{_short(path)}:{number}: '#version' only on a shader's first line"
                    )
                lines.append(line)
                continue
            target = self._resolve(match.group(1), path, where=f"{_short(path)}:{number}")
            if target in stack:
                chain = " -> ".join(_short(p) for p in [*stack, target])
                raise ShaderError(f"{_short(path)}:{number}: #include cycle: {chain}")
            if len(stack) >= MAX_INCLUDE_DEPTH:
                raise ShaderError(
                    f"{_short(path)}:{number}: #include nested deeper than {MAX_INCLUDE_DEPTH}"
                )
            self._splice(target, target.read_text().splitlines(), 0, lines, out, [*stack, target])
            lines.append(f"#line {file_id * LINE_STRIDE + number + 1}")

    def _resolve(self, name: str, parent: Path | None, where: str = "") -> Path:
        candidates = [parent.parent / name] if parent else []
        candidates.append(self.root / name)
        for candidate in candidates:
            if candidate.is_file():
                return candidate.resolve()
        prefix = f"{where}: " if where else ""
        raise ShaderError(f"{prefix}shader file '{name}' not found under {self.root}")

    def program(
        self,
        ctx: moderngl.Context,
        vertex: str,
        fragment: str | None = None,
        geometry: str | None = None,
        *,
        defines: dict[str, object] | None = None,
        tessellation: tuple[str, str] | None = None,
    ) -> moderngl.Program:
        """Compile and link a program from shader files; errors name file and line.
        `tessellation` is (control, evaluation) shader files (GL 4.0)."""
        stages = {
            "vertex_shader": vertex,
            "fragment_shader": fragment,
            "geometry_shader": geometry,
            "tess_control_shader": tessellation[0] if tessellation else None,
            "tess_evaluation_shader": tessellation[1] if tessellation else None,
        }
        sources = {
            stage: self.expand(name, defines) for stage, name in stages.items() if name is not None
        }
        text = {stage: source.text for stage, source in sources.items()}
        try:
            prog = ctx.program(
                vertex_shader=text["vertex_shader"],
                fragment_shader=text.get("fragment_shader"),
                geometry_shader=text.get("geometry_shader"),
                tess_control_shader=text.get("tess_control_shader"),
                tess_evaluation_shader=text.get("tess_evaluation_shader"),
            )
        except moderngl.Error as exc:
            raise ShaderError(self._explain(str(exc), sources)) from None
        prog.extra = _Declared(" + ".join(_short(s.files[0]) for s in sources.values()))
        return prog

    def _explain(self, message: str, sources: dict[str, ExpandedSource]) -> str:
        lines = [ln.strip() for ln in message.splitlines()]
        stage = next((ln for ln in lines if ln in sources), None)
        body = [ln for ln in lines if ln and ln not in sources and not set(ln) <= {"="}]
        detail = next((ln for ln in body if "error" in ln.lower() and _LOCATION.search(ln)), None)
        if stage is None or detail is None:
            # Link errors and unknown formats: name the files and report the most telling line.
            names = ", ".join(_short(s.files[0]) for s in sources.values())
            summary = detail or next(
                (ln for ln in body if "error" in ln.lower()), body[-1] if body else message
            )
            return f"shader program ({names}): {summary}"
        match = _LOCATION.search(detail)
        assert match is not None
        location, text = sources[stage].describe(int(match.group(2)))
        what = detail[match.end() :].lstrip(" :)").strip()
        return f"{location}: {what}" + (f"\n    {text}" if text else "")


def _short(path: Path) -> str:
    try:
        return str(path.relative_to(shaders_dir().parent))
    except ValueError:
        return str(path)


def program(
    gl_cache: dict,
    ctx: moderngl.Context,
    vertex: str,
    *stages: str | None,
    defines: dict[str, object] | None = None,
    tessellation: tuple[str, str] | None = None,
) -> moderngl.Program:
    """A cached program per context and defines: `program(gl.cache, gl.ctx, "a.vert", "a.frag")`
    (then the geometry shader, if any; `tessellation`: the control and evaluation shaders)."""
    names = "|".join([vertex, *(n or "" for n in stages), *(tessellation or ())])
    key = f"program:{names}|{sorted((defines or {}).items())!r}"
    if key not in gl_cache:
        gl_cache[key] = ShaderLibrary().program(
            ctx, vertex, *stages, defines=defines, tessellation=tessellation
        )
    return gl_cache[key]


#: `uniform [qualifiers] type name[, name2[N]];` declarations (no uniform blocks in our shaders).
_UNIFORM = re.compile(r"^\s*uniform\s+(?:(?:lowp|mediump|highp)\s+)?\w+\s+([^;{]+);", re.M)


def uniform_names(source: str) -> list[str]:
    """The uniforms a GLSL source declares, whether or not the compiler keeps them."""
    return [
        part.split("[")[0].strip()
        for match in _UNIFORM.finditer(source)
        for part in match.group(1).split(",")
    ]


@dataclass(frozen=True)
class _Declared:
    """Which files a program was made of (kept on the program as `extra`, for messages), and
    the value set last for each uniform (dentdemo's programs are its own: nothing else sets
    them, so a value set again needs no GL call)."""

    files: str
    last: dict[str, object] = field(default_factory=dict)
    #: Names written to the program that it lacks (its variant dropped them): skipped after.
    absent: set[str] = field(default_factory=set)
    #: Per uniform set once: a function that writes a value of it (`_writer`).
    writers: dict[str, Callable[[object], None]] = field(default_factory=dict)


#: Values compared with the last one set (others, such as numpy arrays, are always set).
_COMPARABLE = (bool, int, float, tuple, bytes)


@functools.cache
def library_uniforms(root: Path | None = None) -> frozenset[str]:
    """Every uniform some shader file under `root` (default: shaders/) declares."""
    folder = root or shaders_dir()
    return frozenset(
        name
        for path in sorted(folder.rglob("*"))
        if path.suffix in {".vert", ".frag", ".geom", ".glsl", ".tesc", ".tese"}
        for name in uniform_names(path.read_text(encoding="utf-8"))
    )


def set_uniforms(
    prog: moderngl.Program, uniforms: Mapping[str, object], selectors: frozenset[str] = frozenset()
) -> None:
    """`set_uniform` of each item, the names the program lacks and the values it already holds
    skipped here without a call (a batch's draws share most of their uniforms)."""
    declared = prog.extra if isinstance(prog.extra, _Declared) else None
    if declared is None:
        for name, value in uniforms.items():
            set_uniform(prog, name, value, selectors)
        return
    absent, last, writers = declared.absent, declared.last, declared.writers
    for name, value in uniforms.items():
        if name in absent:
            continue
        comparable = isinstance(value, _COMPARABLE)
        if comparable and last.get(name, _UNSET) == value:
            continue
        write = writers.get(name)
        if write is None:  # the first time: looked up (and checked) by set_uniform
            set_uniform(prog, name, value, selectors)
            continue
        write(value)
        _remember(last, name, value, comparable)


def _remember(last: dict[str, object], name: str, value: object, comparable: bool) -> None:
    """Keep `value` as the one `name` holds (a value that cannot be compared is forgotten)."""
    if comparable:
        last[name] = value
    else:
        last.pop(name, None)


def _writer(member: moderngl.Uniform) -> Callable[[object], None]:
    """What `set_uniform` does to `member` for a value, in one call: bytes written as they are
    (matrices, column-major float32), else packed by the uniform's format, through moderngl's
    `Uniform.write`; arrays go through `value`."""
    fmt, dimension = getattr(member, "fmt", None), getattr(member, "dimension", None)
    if fmt is None or dimension is None or getattr(member, "array_length", 1) != 1:

        def through_value(value: object) -> None:
            if isinstance(value, bytes):
                member.write(value)
            else:
                member.value = value

        return through_value
    raw = member.write
    pack = struct.Struct(fmt).pack
    many = dimension > 1

    def write(value: object) -> None:
        if isinstance(value, bytes):
            raw(value)
        elif many:
            raw(pack(*value))  # type: ignore[misc]  # a vector: a sequence
        else:
            raw(pack(value))

    return write


def set_uniform(
    prog: moderngl.Program, name: str, value: object, selectors: frozenset[str] = frozenset()
) -> None:
    """Set a uniform if the program has it: a pass's uniforms are shared by its variants and by
    the passes of one hit, and compilers drop uniforms a variant does not use (the normal pass
    never reads the scatter's height, for one), so a name this program lacks is skipped.
    `selectors` are keys that pick a pass's variant rather than name a uniform. A name that no
    shader file declares at all (a misspelling, a uniform renamed in a shader but not in
    Python) raises ShaderError."""
    declared = prog.extra if isinstance(prog.extra, _Declared) else None
    comparable = isinstance(value, _COMPARABLE)
    if declared is not None and comparable and declared.last.get(name, _UNSET) == value:
        return  # already so: a batch's draws share most of their uniforms
    member = prog.get(name, None)  # a dict look-up; `name in prog` walks every member
    if member is None:
        known = name in selectors or name in library_uniforms()
        if not known:
            files = declared.files if declared is not None else "a program"
            raise ShaderError(f"{files}: no shader declares a uniform named '{name}'")
        if known and declared is not None:  # an unknown name is checked again each time
            declared.absent.add(name)
        return
    if not isinstance(member, moderngl.Uniform):
        return
    if declared is None:  # a program made elsewhere: nothing to keep
        _writer(member)(value)
        return
    write = declared.writers.get(name)
    if write is None:
        write = declared.writers[name] = _writer(member)
    write(value)
    _remember(declared.last, name, value, comparable)


_UNSET = object()
