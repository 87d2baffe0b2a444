"""GL context, the shader loader, and an EGL smoke test."""

import ctypes
import os
import subprocess
import sys

import moderngl
import numpy as np
import pytest

from dentdemo.errors import GLUnavailableError, ShaderError
from dentdemo.gl.context import create_headless, release
from dentdemo.gl.shaders import ShaderLibrary


def test_context_is_33_core(gl):
    """Asked of the driver itself, not of moderngl (whose version the context's maker already
    checks): GL_MAJOR_VERSION.GL_MINOR_VERSION >= 3.3 and the core bit of
    GL_CONTEXT_PROFILE_MASK set. MESA_GL_VERSION_OVERRIDE=3.3COMPAT gives a compatibility
    context that passed the old check and fails this one."""
    raw = ctypes.CDLL("libOpenGL.so.0")
    value = ctypes.c_int(0)

    def integer(pname: int) -> int:
        raw.glGetIntegerv(pname, ctypes.byref(value))
        return value.value

    major, minor = integer(0x821B), integer(0x821C)  # GL_MAJOR_VERSION, GL_MINOR_VERSION
    assert (major, minor) >= (3, 3), (major, minor)
    assert integer(0x9126) & 0x1, "not a core profile"  # GL_CONTEXT_PROFILE_MASK, CORE_BIT
    raw.glGetString.restype = ctypes.c_char_p
    assert raw.glGetString(0x1F02).decode().startswith(f"{major}.{minor}")  # GL_VERSION
    assert gl.renderer


def test_egl_triangle_pixels(gl):
    lib = ShaderLibrary()
    prog = lib.program(gl.ctx, "util/flat_colour.vert", "util/flat_colour.frag")
    # A red triangle covering the lower-left half of clip space.
    data = np.array([-1, -1, 1, 0, 0, 1, -1, 1, 0, 0, -1, 1, 1, 0, 0], dtype="f4")
    vbo = gl.ctx.buffer(data.tobytes())
    vao = gl.ctx.vertex_array(prog, [(vbo, "2f 3f", "in_position", "in_colour")])
    fbo = gl.ctx.simple_framebuffer((32, 32))
    fbo.use()
    fbo.clear(0.0, 0.0, 1.0, 1.0)
    vao.render(moderngl.TRIANGLES)
    pixels = gl.read_framebuffer(fbo)
    assert tuple(pixels[2, 2]) == (255, 0, 0)  # row 0 is the bottom: inside the triangle
    assert tuple(pixels[29, 29]) == (0, 0, 255)  # top right: outside
    release(vao, vbo, fbo)


def test_unknown_backend_is_a_clear_error():
    with pytest.raises(GLUnavailableError, match="unknown GL backend 'vulkan'"):
        create_headless("vulkan")


def test_no_context_names_what_to_install():
    # An EGL library that cannot be loaded stands in for a machine without EGL.
    code = (
        "import os; os.environ['GLCONTEXT_LINUX_LIBEGL']='/nonexistent/libEGL.so';"
        "from dentdemo.gl.context import create_headless, release\n"
        "from dentdemo.errors import GLUnavailableError\n"
        "try:\n    create_headless('egl')\nexcept GLUnavailableError as e:\n    print(e)\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert "libegl1" in result.stdout and "3.3" in result.stdout


@pytest.fixture
def shader_tree(tmp_path):
    def write(files: dict[str, str]) -> ShaderLibrary:
        for name, text in files.items():
            path = tmp_path / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
        return ShaderLibrary(tmp_path)

    return write


VERT = "#version 330 core\nin vec2 p;\nvoid main() { gl_Position = vec4(p, 0.0, 1.0); }\n"


def test_include_is_spliced_with_line_markers(shader_tree):
    lib = shader_tree(
        {
            "a.frag": '#version 330 core\n#include "inc/b.glsl"\nout vec4 c;\n'
            "void main() { c = f(); }\n",
            "inc/b.glsl": '#include "c.glsl"\nvec4 f() { return g(); }\n',
            "inc/c.glsl": "vec4 g() { return vec4(1.0); }\n",
        }
    )
    src = lib.expand("a.frag")
    assert src.text.splitlines()[0] == "#version 330 core"
    assert "vec4 g()" in src.text and "vec4 f()" in src.text
    assert [p.name for p in src.files] == ["a.frag", "b.glsl", "c.glsl"]
    assert "#line 3" in src.text  # back in a.frag (file 0) after the include
    assert "#line 100001" in src.text  # b.glsl (file 1) from its first line


def test_include_cycle_is_reported(shader_tree):
    lib = shader_tree(
        {
            "a.frag": '#version 330 core\n#include "b.glsl"\n',
            "b.glsl": '#include "c.glsl"\n',
            "c.glsl": '#include "b.glsl"\n',
        }
    )
    with pytest.raises(
        ShaderError, match=r"c.glsl:1: #include cycle: .*b.glsl -> .*c.glsl -> .*b.glsl"
    ):
        lib.expand("a.frag")


def test_include_depth_limit(shader_tree):
    files = {"a.frag": '#version 330 core\n#include "i0.glsl"\n'}
    for i in range(20):
        files[f"i{i}.glsl"] = f'#include "i{i + 1}.glsl"\n'
    files["i20.glsl"] = "// end\n"
    with pytest.raises(ShaderError, match="deeper than 16"):
        shader_tree(files).expand("a.frag")


def test_missing_include_and_missing_version(shader_tree):
    lib = shader_tree(
        {"a.frag": '#version 330 core\n\n#include "nope.glsl"\n', "b.frag": "void main() {}\n"}
    )
    with pytest.raises(ShaderError, match=r"a.frag:3: shader file 'nope.glsl' not found"):
        lib.expand("a.frag")
    with pytest.raises(
        ShaderError, match=r"b.frag:1: a shader must start with '#version 330 core'"
    ):
        lib.expand("b.frag")


def test_compile_error_names_included_file_and_line(gl, shader_tree):
    lib = shader_tree(
        {
            "v.vert": VERT,
            "f.frag": '#version 330 core\n#include "helpers.glsl"\nout vec4 c;\n'
            "void main() { c = h(); }\n",
            "helpers.glsl": "// helpers\nvec4 h() {\n    return vec4(undefined_thing);\n}\n",
        }
    )
    with pytest.raises(ShaderError) as info:
        lib.program(gl.ctx, "v.vert", "f.frag")
    message = str(info.value)
    assert "helpers.glsl:3:" in message
    assert "undefined_thing" in message  # the offending source line is shown


def test_compile_error_in_main_file_after_include(gl, shader_tree):
    lib = shader_tree(
        {
            "v.vert": VERT,
            "f.frag": '#version 330 core\n#include "ok.glsl"\nout vec4 c;\n'
            "void main() { c = vec3(1.0); }\n",
            "ok.glsl": "float ok() { return 1.0; }\n",
        }
    )
    with pytest.raises(ShaderError, match=r"f.frag:4:"):
        lib.program(gl.ctx, "v.vert", "f.frag")


def test_glx_backend_under_xvfb(xvfb):
    """DENTDEMO_GL_BACKEND=glx makes a GLX context on an X display (here Xvfb) and runs a press."""
    import subprocess
    import sys

    code = (
        "from dentdemo.gl.context import create_headless;"
        "gl = create_headless();"
        "print(gl.backend, gl.ctx.version_code)"
    )
    env = {**os.environ, "DISPLAY": xvfb, "DENTDEMO_GL_BACKEND": "glx"}
    run = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert run.returncode == 0, run.stderr
    backend, version = run.stdout.split()
    assert backend == "glx" and int(version) >= 330


def test_glx_backend_without_display_is_one_line(monkeypatch):
    from dentdemo.errors import GLUnavailableError
    from dentdemo.gl.context import create_headless

    monkeypatch.delenv("DISPLAY", raising=False)
    with pytest.raises(GLUnavailableError) as info:
        create_headless("glx")
    assert "DISPLAY" in str(info.value) and "libglx-mesa0" in str(info.value)
    assert "\n" not in str(info.value)


def test_uniform_declarations_are_read_from_the_source():
    source = (
        "#version 330 core\n"
        "uniform highp vec3 u_a;\n"
        "  uniform float u_b, u_c[4];\n"
        "uniform sampler2D u_map;  // a comment\n"
        "vec3 f(vec3 uniformity) { return uniformity; }\n"
    )
    from dentdemo.gl.shaders import uniform_names

    assert uniform_names(source) == ["u_a", "u_b", "u_c", "u_map"]


def test_a_uniform_no_shader_declares_raises(gl):
    from dentdemo.carve.texel_passes import texture_space_passes
    from dentdemo.gl.shaders import library_uniforms

    normals = texture_space_passes(gl)["normals", 0, False]
    target = gl.ctx.texture((4, 4), 4)
    fbo = gl.ctx.framebuffer([target])
    draw = lambda prog: None  # noqa: E731 (no geometry: only the uniforms are written)
    # u_map_size is texel.geom's, which this variant lacks: skipped, as a shared dict needs.
    assert "u_map_size" in library_uniforms() and "u_map_size" not in normals.program
    normals.run(gl.ctx, fbo, (0, 0, 4, 4), draw, (target, target), {"u_map_size": (4, 4)})
    # A variant selector is not a uniform.
    normals.run(gl.ctx, fbo, (0, 0, 4, 4), draw, (target, target), {"u_swept": True})
    # Always, with no environment to switch it: skipped names are remembered per program, but
    # only those some shader declares, so the misspelt one raises each time.
    for _ in range(2):
        with pytest.raises(ShaderError, match="u_map_sise"):
            normals.run(gl.ctx, fbo, (0, 0, 4, 4), draw, (target, target), {"u_map_sise": (4, 4)})
    normals.run(gl.ctx, fbo, (0, 0, 4, 4), draw, (target, target), {"u_map_size": (4, 4)})
    assert "u_map_size" in normals.program.extra.absent
    release(fbo, target)


def test_each_carve_program_is_held_to_its_familys_typed_uniforms(gl):
    """A program that keeps a uniform its family's dataclass lacks is refused when it is built
    (naming the program and the uniform), and so is a family field that no shader declares."""
    from dataclasses import dataclass
    from typing import ClassVar

    from dentdemo.carve.params import (
        Camera,
        Pose,
        SurfaceUniforms,
        TexelUniforms,
        _Family,
        check_program,
        family_names,
    )
    from dentdemo.carve.texel_passes import texture_space_passes

    passes = texture_space_passes(gl)
    gather = passes["gather", 0, False, True, False]
    check_program(gather.program, TexelUniforms, gather.samplers, "gather")  # as built
    assert "u_min_height" in gather.program
    with pytest.raises(ShaderError, match=r"gather.*u_min_height.*SurfaceUniforms"):
        check_program(gather.program, SurfaceUniforms, gather.samplers, "gather")
    with pytest.raises(ShaderError, match="u_address"):  # its samplers are named by the pass
        check_program(gather.program, TexelUniforms, (), "gather")

    @dataclass(frozen=True)
    class Misspelt:
        u_eyes: tuple[float, float, float]

    @dataclass(frozen=True)
    class Family(_Family):
        GROUPS: ClassVar[tuple[type, ...]] = (Camera, Pose, Misspelt)

    with pytest.raises(ShaderError, match="u_eyes"):
        family_names(Family)


def test_a_uniform_set_again_to_its_value_is_skipped_and_a_new_value_is_not(gl):
    from dentdemo.carve.texel_passes import texture_space_passes
    from dentdemo.gl.shaders import set_uniform

    prog = texture_space_passes(gl)["normals", 1, False].program
    writes = []
    member = prog["u_map_size"]
    for value in [(8, 8), (8, 8), (16, 4), (16, 4), (8, 8)]:
        before = prog.extra.last.get("u_map_size")
        set_uniform(prog, "u_map_size", value)
        writes.append(before != value)
        assert tuple(member.value) == value  # what GL holds, read back
    assert writes == [True, False, True, False, True]


def test_a_shared_batch_draws_each_pass_with_its_program_and_refuses_other_state(gl):
    """Two programs under one state in one shared batch each draw with their own program (a
    full-screen triangle writing 0.25, then one writing 0.75 over its left half); a pass whose
    state differs from the batch's is refused before it draws."""
    from dentdemo.gl.passes import Pass, PassState, shared_batch

    ctx = gl.ctx
    vert = (
        "#version 330 core\nvoid main() { vec2 p = vec2((gl_VertexID & 1) * 4 - 1,"
        " (gl_VertexID >> 1) * 4 - 1); gl_Position = vec4(p, 0.0, 1.0); }"
    )

    def frag(value: float) -> str:
        return f"#version 330 core\nout vec4 f;\nvoid main() {{ f = vec4({value}); }}"

    state = PassState()
    low = Pass("low", ctx.program(vertex_shader=vert, fragment_shader=frag(0.25)), state)
    high = Pass("high", ctx.program(vertex_shader=vert, fragment_shader=frag(0.75)), state)
    other = Pass("other", high.program, PassState(cull="back"))
    target = ctx.texture((8, 4), 4, dtype="f4")
    fbo = ctx.framebuffer([target])
    vaos = {p.glo: ctx.vertex_array(p, []) for p in (low.program, high.program)}

    def draw(prog):
        vaos[prog.glo].render(moderngl.TRIANGLES, vertices=3)

    try:
        with shared_batch(ctx, fbo, state) as one:
            one(low, (0, 0, 8, 4), draw)
            one(high, (0, 0, 4, 4), draw)
            with pytest.raises(ValueError, match="other"):
                one(other, (0, 0, 8, 4), draw)
        red = gl.read(target)[..., 0]  # rows, columns
        assert np.all(red[:, :4] == 0.75) and np.all(red[:, 4:] == 0.25)
    finally:
        release(*vaos.values(), fbo, target, low.program, high.program)


def test_a_shared_batch_binds_only_what_changed_and_each_draw_samples_its_own(gl, monkeypatch):
    """A shared batch of draws that sample textures of known values (2, 3, 5) through one
    unit, first plain, then through a NEAREST sampler object, into two framebuffers with one
    viewport: each draw writes the value of the texture it names, over its viewport only,
    also after the framebuffer changes (binding one sets its own whole viewport). A draw whose
    texture is the unit's already binds nothing, and the sampler is named to its unit once."""
    from dentdemo.gl import passes
    from dentdemo.gl.passes import Pass, PassState, shared_batch

    ctx = gl.ctx
    vert = (
        "#version 330 core\nvoid main() { vec2 p = vec2((gl_VertexID & 1) * 4 - 1,"
        " (gl_VertexID >> 1) * 4 - 1); gl_Position = vec4(p, 0.0, 1.0); }"
    )
    frag = (
        "#version 330 core\nuniform sampler2D u_source;\nout vec4 f;\n"
        "void main() { f = texelFetch(u_source, ivec2(0), 0); }"
    )
    copy = Pass("copy", ctx.program(vertex_shader=vert, fragment_shader=frag), PassState())
    copy = Pass(copy.name, copy.program, copy.state, ("u_source",))
    sources = [ctx.texture((1, 1), 1, np.float32([v]).tobytes(), dtype="f4") for v in (2, 3, 5)]
    sampler = ctx.sampler(filter=(moderngl.NEAREST, moderngl.NEAREST))
    targets = [ctx.texture((8, 4), 1, dtype="f4") for _ in range(2)]
    fbos = [ctx.framebuffer([t]) for t in targets]
    vao = ctx.vertex_array(copy.program, [])
    binds, named = [], []
    real_bind, real_name = passes.bind, passes.set_uniform
    monkeypatch.setattr(passes, "bind", lambda *a: binds.append(a[1]) or real_bind(*a))
    monkeypatch.setattr(passes, "set_uniform", lambda *a: named.append(a[1]) or real_name(*a))

    def draw(prog):
        vao.render(moderngl.TRIANGLES, vertices=3)

    a, b, c = sources
    try:
        for fbo in fbos:
            fbo.clear(-1.0, -1.0, -1.0, -1.0)
        with shared_batch(ctx, fbos[0], copy.state) as one:
            one(copy, (0, 0, 2, 4), draw, (a,))
            one(copy, (2, 0, 2, 4), draw, (a,))  # the same texture: no bind
            one(copy, (4, 0, 2, 4), draw, (b,))
            one(copy, (6, 0, 2, 4), draw, ((c, sampler),))
            one(copy, (6, 0, 2, 4), draw, ((c, sampler),), into=fbos[1])  # no bind
            one(copy, (0, 0, 2, 4), draw, (a,), into=fbos[1])
        assert binds == [a, b, (c, sampler), a]
        assert named == ["u_source"]  # the program keeps its sampler's unit for the batch
        first, second = (gl.read(t)[..., 0] for t in targets)  # rows, columns
        assert np.all(first[:, :4] == 2.0) and np.all(first[:, 4:6] == 3.0)
        assert np.all(first[:, 6:] == 5.0)
        assert np.all(second[:, 6:] == 5.0) and np.all(second[:, :2] == 2.0)
        assert np.all(second[:, 2:6] == -1.0)  # the viewports held after the switch
    finally:
        release(vao, *fbos, *targets, *sources, sampler, copy.program)


def test_set_uniforms_writes_each_kind_of_uniform_every_time_it_changes(gl):
    """set_uniforms on a library program (its writers cached after the first write of each
    name) writes floats, vectors, integer vectors, booleans and column-major matrices: read back
    from GL after each of three rounds of new values, every uniform holds what was set last."""
    from dentdemo.carve.constants import shader_defines
    from dentdemo.gl.shaders import ShaderLibrary, set_uniforms

    defines = shader_defines(GUTTER=1)  # the gutter variant: u_map_size is an ivec2
    prog = ShaderLibrary().program(
        gl.ctx, "carve/texel.vert", "carve/normals.frag", "carve/texel.geom", defines=defines
    )
    rng = np.random.default_rng(3)
    for _ in range(3):
        model = rng.normal(size=(4, 4))
        values = {
            "u_eye": tuple(rng.normal(size=3)),
            "u_clip_half": tuple(rng.uniform(0.1, 1.0, size=2)),
            "u_map_size": tuple(int(v) for v in rng.integers(1, 500, size=2)),
            "u_clip": bool(rng.integers(0, 2)),
            "u_model": model.T.astype("f4").tobytes(),  # column-major
        }
        set_uniforms(prog, values)
        assert prog["u_eye"].value == pytest.approx(values["u_eye"], rel=1e-6)
        assert prog["u_clip_half"].value == pytest.approx(values["u_clip_half"], rel=1e-6)
        assert prog["u_map_size"].value == values["u_map_size"]
        assert bool(prog["u_clip"].value) == values["u_clip"]
        read = np.frombuffer(prog["u_model"].read(), "f4").reshape(4, 4).T
        assert np.array_equal(read, model.astype("f4"))
    prog.release()
