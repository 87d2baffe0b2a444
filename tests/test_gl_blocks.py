"""Uniform blocks (gl/blocks.py): the std140 layout worked out from the carve's job block is the
one the driver reports for it, values packed into it read back in a shader as they were given
(members no part names read zero), and the stream writes a block once for the same values and
puts each at the driver's offset alignment."""

from __future__ import annotations

import ctypes

import moderngl
import numpy as np
import pytest

from dentdemo.gl.blocks import BlockLayout, BlockStream, packer
from dentdemo.gl.context import release
from dentdemo.gl.library import gl_library
from dentdemo.gl.shaders import shaders_dir

_UNIFORM_OFFSET, _BLOCK_DATA_SIZE = 0x8A3B, 0x8A40


def _job_layout() -> BlockLayout:
    return BlockLayout.of_file("carve/job.glsl")


def test_the_job_blocks_layout_is_the_one_the_driver_reports(gl):
    """Each member's byte offset and the block's size, as GL reports them for a carve program
    that declares the block (glGetActiveUniformsiv, glGetActiveUniformBlockiv)."""
    from dentdemo.carve.texel_passes import texture_space_passes

    layout = _job_layout()
    prog = texture_space_passes(gl)["gather", 1, True, True, True].program
    raw = gl_library()
    names = [name for name, _, _ in layout.members]
    strings = (ctypes.c_char_p * len(names))(*(n.encode() for n in names))
    indices = (ctypes.c_uint * len(names))()
    raw.glGetUniformIndices(prog.glo, len(names), strings, indices)
    assert 0xFFFFFFFF not in list(indices), "a member the driver does not know"
    offsets = (ctypes.c_int * len(names))()
    raw.glGetActiveUniformsiv(prog.glo, len(names), indices, _UNIFORM_OFFSET, offsets)
    assert dict(zip(names, offsets, strict=True)) == {n: o for n, _, o in layout.members}
    block = raw.glGetUniformBlockIndex(prog.glo, layout.name.encode())
    size = ctypes.c_int()
    raw.glGetActiveUniformBlockiv(prog.glo, block, _BLOCK_DATA_SIZE, ctypes.byref(size))
    assert size.value == layout.size


#: What the read-back shader writes per output texel: a vec4 of members (ints as floats).
_READS = [
    *(f"u_model[{k}]" for k in range(4)),
    *(f"vec4(u_normal_matrix[{k}], 0.0)" for k in range(3)),
    *(f"vec4(u_swept_local[{k}], 0.0)" for k in range(3)),
    "vec4(u_eye, u_advance)",
    "vec4(u_right, u_near_clip)",
    "vec4(u_up, u_min_height)",
    "vec4(u_forward, u_ceiling)",
    "vec4(u_swept_a, u_swept_radius)",
    "vec4(u_swept_b, u_pixel_diagonal)",
    "vec4(u_capsule, u_cube_radius)",
    "vec4(u_half_extent, u_depth_range)",
    "vec4(vec2(u_resolution), vec2(u_tile))",
    "vec4(u_clip_half, u_slab)",
    "vec4(vec2(u_map_size), float(u_cube_grid), u_clip ? 1.0 : 0.0)",
]


def _expected(values: dict[str, object]) -> np.ndarray:
    """The texels the read-back shader should write for `values`, by hand (absent: 0)."""

    def get(name: str, n: int) -> list[float]:
        v = values.get(name)
        if v is None:
            return [0.0] * n
        if isinstance(v, bytes):
            return list(np.frombuffer(v, "<f4").astype(np.float64))
        return [float(x) for x in (v if isinstance(v, tuple) else (v,))]

    model = np.array(get("u_model", 16)).reshape(4, 4)  # rows are columns (column-major)
    normal = np.array(get("u_normal_matrix", 9)).reshape(3, 3)
    local = np.array(get("u_swept_local", 9)).reshape(3, 3)
    rows = [list(model[k]) for k in range(4)]
    rows += [[*normal[k], 0.0] for k in range(3)] + [[*local[k], 0.0] for k in range(3)]
    pairs = [
        ("u_eye", "u_advance"),
        ("u_right", "u_near_clip"),
        ("u_up", "u_min_height"),
        ("u_forward", "u_ceiling"),
        ("u_swept_a", "u_swept_radius"),
        ("u_swept_b", "u_pixel_diagonal"),
        ("u_capsule", "u_cube_radius"),
    ]
    rows += [get(a, 3) + get(b, 1) for a, b in pairs]
    rows += [get("u_half_extent", 2) + get("u_depth_range", 2)]
    rows += [get("u_resolution", 2) + get("u_tile", 2)]
    rows += [get("u_clip_half", 2) + get("u_slab", 2)]
    clip = values.get("u_clip")
    rows += [get("u_map_size", 2) + get("u_cube_grid", 1) + [1.0 if clip else 0.0]]
    return np.array(rows, dtype=np.float32)


@pytest.mark.parametrize("seed", [1, 2])
def test_packed_job_blocks_read_back_as_given(gl, seed):
    """Random values of every member, given as two parts (the second overriding some of the
    first) and with some members left out, drawn through a program that declares the block
    (job.glsl) and writes each member out: every value as given (float32), those left out 0."""
    ctx = gl.ctx
    rng = np.random.default_rng(seed)
    source = (shaders_dir() / "carve/job.glsl").read_text()
    cases = "\n".join(f"    if (i == {k}) f = {read};" for k, read in enumerate(_READS))
    frag = (
        f"#version 330 core\n{source}\nout vec4 f;\nvoid main() {{\n"
        f"    int i = int(gl_FragCoord.x);\n    f = vec4(-1.0);\n{cases}\n}}\n"
    )
    vert = (
        "#version 330 core\nvoid main() { vec2 p = vec2((gl_VertexID & 1) * 4 - 1,"
        " (gl_VertexID >> 1) * 4 - 1); gl_Position = vec4(p, 0.0, 1.0); }"
    )
    prog = ctx.program(vertex_shader=vert, fragment_shader=frag)

    def vec(n: int) -> tuple[float, ...]:
        return tuple(float(x) for x in rng.normal(size=n))

    def ivec(n: int) -> tuple[int, ...]:
        return tuple(int(x) for x in rng.integers(-500, 500, size=n))

    first: dict[str, object] = {
        "u_model": rng.normal(size=16).astype("<f4").tobytes(),
        "u_normal_matrix": rng.normal(size=9).astype("<f4").tobytes(),
        "u_swept_local": rng.normal(size=9).astype("<f4").tobytes(),
        **{name: vec(3) for name in ("u_eye", "u_right", "u_up", "u_forward", "u_swept_a")},
        **{name: vec(3) for name in ("u_swept_b",)},
        **{name: float(rng.normal()) for name in ("u_advance", "u_near_clip", "u_min_height")},
        **{name: float(rng.normal()) for name in ("u_ceiling", "u_swept_radius")},
        **{name: vec(2) for name in ("u_half_extent", "u_depth_range", "u_clip_half")},
        **{name: ivec(2) for name in ("u_resolution", "u_tile", "u_map_size")},
        "u_cube_grid": int(rng.integers(1, 40)),
        "u_clip": bool(seed % 2),
        "u_swept": True,  # a selector: no member, not packed
    }
    second: dict[str, object] = {"u_eye": vec(3), "u_slab": vec(2), "u_clip": not first["u_clip"]}
    # Left out: u_capsule, u_cube_radius, u_pixel_diagonal.
    layout = _job_layout()
    stream = BlockStream(ctx)
    target = ctx.texture((len(_READS), 1), 4, dtype="f4")
    fbo = ctx.framebuffer([target])
    vao = ctx.vertex_array(prog, [])
    try:
        at = stream.place(packer(layout), (first, second))
        assert at % stream.align == 0
        stream.bind(at, layout.size)
        fbo.use()
        vao.render(moderngl.TRIANGLES, vertices=3)
        got = np.frombuffer(target.read(), "<f4").reshape(len(_READS), 4)
        expected = _expected(first | second)
        np.testing.assert_array_equal(got, expected)
    finally:
        release(vao, fbo, target, prog)
        stream.release()


def test_the_stream_writes_the_same_parts_once_and_aligns_each_block(gl):
    """The same mapping objects again give the same offset and write nothing; other parts (or
    equal values in new mappings) a new block past the last, at the driver's alignment; a block
    past the capacity starts the buffer over."""
    layout = _job_layout()
    pack = packer(layout)
    stream = BlockStream(gl.ctx, capacity=4 * layout.size + 3 * 256)
    writes = []
    real = stream.buffer.write
    stream.buffer.write = lambda data, offset=0: writes.append(offset) or real(data, offset=offset)
    try:
        a, b = {"u_advance": 1.0}, {"u_advance": 2.0}
        first = stream.place(pack, (a,))
        assert stream.place(pack, (a,)) == first and writes == [first]
        second = stream.place(pack, (b,))
        third = stream.place(pack, ({"u_advance": 2.0},))
        assert first < second < third and len(writes) == 3
        for offset in (second, third):
            assert offset % stream.align == 0 and offset >= layout.size
        offsets = [stream.place(pack, ({"u_advance": float(k)},)) for k in range(8)]
        assert 0 in offsets[1:]  # started over
    finally:
        stream.release()
