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
    # u_rect is rect.vert's, which this variant lacks: skipped, as a shared dict needs.
    assert "u_rect" in library_uniforms() and "u_rect" not in normals.program
    normals.run(gl.ctx, fbo, (0, 0, 4, 4), draw, (target, target), {"u_rect": (0, 0, 4, 4)})
    # A variant selector is not a uniform.
    normals.run(gl.ctx, fbo, (0, 0, 4, 4), draw, (target, target), {"u_swept": True})
    # Always, with no environment to switch it: skipped names are remembered per program, but
    # only those some shader declares, so the misspelt one raises each time; and so does a
    # value of the job table's entries (job.glsl) given as a uniform.
    for name in ("u_rekt", "u_rekt", "u_eye"):
        with pytest.raises(ShaderError, match=name):
            normals.run(gl.ctx, fbo, (0, 0, 4, 4), draw, (target, target), {name: (4, 4)})
    normals.run(gl.ctx, fbo, (0, 0, 4, 4), draw, (target, target), {"u_rect": (0, 0, 4, 4)})
    assert "u_rect" in normals.program.extra.absent
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
    gather = passes["gather", 2, True, True, True]  # RECT: util/rect.vert's u_rect_first
    check_program(gather.program, TexelUniforms, gather.samplers, "gather")  # as built
    assert "u_rect_first" in gather.program
    with pytest.raises(ShaderError, match=r"gather.*u_rect_first.*SurfaceUniforms"):
        check_program(gather.program, SurfaceUniforms, gather.samplers, "gather")
    with pytest.raises(ShaderError, match="u_tool_depth"):  # its samplers are named by the pass
        check_program(gather.program, TexelUniforms, (), "gather")

    @dataclass(frozen=True)
    class Misspelt:
        u_eyes: tuple[float, float, float]

    @dataclass(frozen=True)
    class Family(_Family):
        GROUPS: ClassVar[tuple[type, ...]] = (Camera, Pose, Misspelt)

    with pytest.raises(ShaderError, match="u_eyes"):
        family_names(Family)


def test_the_job_tables_layout_is_held_to_the_drivers_and_to_the_parameter_groups(gl, monkeypatch):
    """Every carve program reads the job table (job.glsl's std140 entries) at the offsets the
    driver gives its members; a program whose entry is laid out otherwise (two members swapped)
    is refused at build time, naming the member and both offsets. The entry's members are the
    fields of the parameter groups it is filled from, and a source that lacks one is refused."""
    from dataclasses import fields

    from dentdemo.carve import params
    from dentdemo.carve.jobs import EntryLayout, check_layout, entry_layout
    from dentdemo.carve.params import ENTRY_GROUPS, check_entry
    from dentdemo.carve.texel_passes import texture_space_passes
    from dentdemo.gl.shaders import shaders_dir

    layout = entry_layout()
    assert layout.names() == {f.name for group in ENTRY_GROUPS for f in fields(group)}
    # std140 by hand: a mat4 is 64 bytes, a mat3 three 16-byte columns, a vec3 aligned to 16.
    offsets = {name: at for name, _, at in layout.members}
    assert (offsets["u_normal_matrix"], offsets["u_swept_local"], offsets["u_eye"]) == (
        64,
        112,
        160,
    )
    assert (offsets["u_advance"], offsets["u_right"]) == (172, 176)
    assert layout.stride % 16 == 0 and layout.stride >= offsets["u_clip"] + 4
    for pass_ in texture_space_passes(gl).values():  # as built: they passed the check
        check_layout(pass_.program, "as built")

    source = (shaders_dir() / "carve/job.glsl").read_text(encoding="utf-8")
    swapped = (
        source.replace("    vec3 eye;", "    float SWAP;")
        .replace("    float advance;", "    vec3 eye;")
        .replace("    float SWAP;", "    float advance;")
    )
    assert swapped != source
    vertex = (
        "#version 330 core\n#define JOB_ENTRIES 40\n" + swapped + "\nvoid main() {"
        " gl_Position = vec4(u_eye, u_advance); }"
    )
    fragment = "#version 330 core\nout vec4 f;\nvoid main() { f = vec4(1.0); }"
    prog = gl.ctx.program(vertex_shader=vertex, fragment_shader=fragment)
    with pytest.raises(
        ShaderError, match=r"u_entries\[0\]\.eye lies at byte 176, carve/jobs.py packs 160"
    ):
        check_layout(prog, "swapped")
    prog.release()
    check_entry()  # as built
    lacking = EntryLayout(source.replace("    vec2 ring_slab;", ""))
    assert lacking.names() == layout.names() - {"u_ring_slab"}
    monkeypatch.setattr(params, "entry_layout", lambda: lacking)
    with pytest.raises(ShaderError, match=r"CarveEntry lacks \['u_ring_slab'\]"):
        check_entry()


def test_a_uniform_set_again_to_its_value_is_skipped_and_a_new_value_is_not(gl):
    from dentdemo.carve.texel_passes import texture_space_passes
    from dentdemo.gl.shaders import set_uniform

    prog = texture_space_passes(gl)["normals", 2, False].program
    writes = []
    member = prog["u_viewport"]
    for value in [(8.0, 8.0), (8.0, 8.0), (16.0, 4.0), (16.0, 4.0), (8.0, 8.0)]:
        before = prog.extra.last.get("u_viewport")
        set_uniform(prog, "u_viewport", value)
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


def test_a_shared_batch_sets_a_viewport_only_where_binding_the_framebuffer_left_another(
    gl, monkeypatch
):
    """Binding a framebuffer gives GL the viewport moderngl recorded for it (its whole size
    until a viewport is set while it is bound), unless that is empty: then GL keeps the one it
    had. A shared batch draws into A over its left half, into B (another size) whole, into A
    whole, into A over an empty viewport (as `Carver.warm` does: no fragment), into B whole and
    into A over the empty viewport again: the viewport is set for each of A's draws (binding A
    gives it its last non-empty one, then none) and for none of B's, and each draw covers its
    viewport only: A all the whole draw's value, B all written."""
    from dentdemo.gl.passes import Pass, PassState, shared_batch

    ctx = gl.ctx
    vert = (
        "#version 330 core\nvoid main() { vec2 p = vec2((gl_VertexID & 1) * 4 - 1,"
        " (gl_VertexID >> 1) * 4 - 1); gl_Position = vec4(p, 0.0, 1.0); }"
    )
    frag = (
        "#version 330 core\nuniform float u_value;\nout vec4 f;\nvoid main() { f = vec4(u_value); }"
    )
    fill = Pass("fill", ctx.program(vertex_shader=vert, fragment_shader=frag), PassState())
    targets = [ctx.texture(size, 1, dtype="f4") for size in ((8, 4), (16, 2))]
    fbos = [ctx.framebuffer([t]) for t in targets]
    vao = ctx.vertex_array(fill.program, [])
    viewport = moderngl.Context.viewport
    set_to: list[tuple[int, ...]] = []
    monkeypatch.setattr(
        moderngl.Context,
        "viewport",
        property(viewport.fget, lambda c, v: set_to.append(tuple(v)) or viewport.fset(c, v)),
    )

    def draw(prog):
        vao.render(moderngl.TRIANGLES, vertices=3)

    a, b = fbos
    try:
        for fbo in fbos:
            fbo.clear(-1.0, -1.0, -1.0, -1.0)
        with shared_batch(ctx, a, fill.state) as one:
            one(fill, (0, 0, 4, 4), draw, (), {"u_value": 1.0})
            one(fill, (0, 0, 16, 2), draw, (), {"u_value": 2.0}, into=b)
            one(fill, (0, 0, 8, 4), draw, (), {"u_value": 3.0}, into=a)
            one(fill, (0, 0, 0, 0), draw, (), {"u_value": 5.0})  # no fragment
            one(fill, (0, 0, 16, 2), draw, (), {"u_value": 2.0}, into=b)
            one(fill, (0, 0, 0, 0), draw, (), {"u_value": 5.0}, into=a)  # none again
        assert set_to == [(0, 0, 4, 4), (0, 0, 8, 4), (0, 0, 0, 0), (0, 0, 0, 0)]
        first, second = (gl.read(t)[..., 0] for t in targets)  # rows, columns
        assert np.all(first == 3.0) and np.all(second == 2.0)
    finally:
        release(vao, *fbos, *targets, fill.program)


def test_set_uniforms_writes_each_kind_of_uniform_every_time_it_changes(gl):
    """set_uniforms on library programs (their writers cached after the first write of each
    name) writes floats, vectors, integers, integer vectors and column-major matrices: read back
    from GL after each of three rounds of new values, every uniform holds what was set last."""
    from dentdemo.gl.shaders import ShaderLibrary, set_uniforms

    sky = ShaderLibrary().program(gl.ctx, "util/fullscreen.vert", "render/sky.frag")
    bake = ShaderLibrary().program(gl.ctx, "util/fullscreen.vert", "render/bake_environment.frag")
    rng = np.random.default_rng(3)
    for _ in range(3):
        model = rng.normal(size=(4, 4))
        values = {
            "u_inverse_view_proj": model.T.astype("f4").tobytes(),  # column-major
            "u_viewport": tuple(rng.uniform(0.1, 1.0, size=2)),
            "u_exposure": float(rng.uniform(0.1, 1.0)),
            "u_levels": int(rng.integers(1, 9)),
        }
        baked = {
            "u_sun_dir": tuple(rng.normal(size=3)),
            "u_level_size": tuple(int(v) for v in rng.integers(1, 500, size=2)),
        }
        set_uniforms(sky, values)
        set_uniforms(bake, baked)
        assert sky["u_viewport"].value == pytest.approx(values["u_viewport"], rel=1e-6)
        assert sky["u_exposure"].value == pytest.approx(values["u_exposure"], rel=1e-6)
        assert sky["u_levels"].value == values["u_levels"]
        assert bake["u_sun_dir"].value == pytest.approx(baked["u_sun_dir"], rel=1e-6)
        assert bake["u_level_size"].value == baked["u_level_size"]
        read = np.frombuffer(sky["u_inverse_view_proj"].read(), "f4").reshape(4, 4).T
        assert np.array_equal(read, model.astype("f4"))
    sky.release()
    bake.release()
