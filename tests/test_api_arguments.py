"""Every bad argument of the public API is a ValueError naming the argument and its value, raised
before any GPU work; a trimesh.Trimesh is taken as a mesh; a released surface or carver says so.
Each case failed on the main this branch started from with a raw error, or not at all."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import trimesh

import dentdemo
from dentdemo.errors import ArgumentError
from dentdemo.gl.context import create_headless
from mesh_helpers import grid

PLATE = dentdemo.shape_mesh(dentdemo.Plate(0.4))
BALL = dentdemo.shape_mesh(dentdemo.Sphere(0.05))
DOWN = dentdemo.Contact((0.0, 0.0, 0.0), (0.0, -1.0, 0.0))
MIRROR = np.diag([1.0, 1.0, -1.0, 1.0])
PERSPECTIVE = np.eye(4)
PERSPECTIVE[3] = (0.0, 0.0, -1.0, 0.0)
FLAT = np.diag([1.0, 0.0, 1.0, 1.0])


def _raises(call, *fragments: str) -> str:
    """The ValueError `call` raises; its message holds every fragment."""
    with pytest.raises(ValueError) as info:
        call()
    assert isinstance(info.value, ArgumentError)  # also a DentdemoError: one line in the CLI
    message = str(info.value)
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    assert "\n" not in message
    return message


def _ball_above(ctx, size: int = 64) -> dentdemo.DentableSurface:
    ball = dentdemo.DentableSurface(ctx, BALL, size)
    ball.model[1, 3] = 0.05  # resting on the plate's top face at the origin
    return ball


@pytest.mark.parametrize(
    ("kwargs", "fragments"),
    [
        ({"map_size": 0}, ("map_size", "16 to 4096", "got 0")),
        ({"map_size": 8192}, ("map_size", "16 to 4096", "got 8192")),
        ({"map_size": 15}, ("map_size", "got 15")),
        ({"map_size": 256.0}, ("map_size", "whole number", "got 256.0")),
        ({"map_size": "256"}, ("map_size", "got '256'")),
        ({"map_size": True}, ("map_size", "got True")),
        ({"max_dent_depth": -1}, ("max_dent_depth", "got -1")),
        ({"max_dent_depth": 0.0}, ("max_dent_depth", "> 0", "got 0.0")),
        ({"max_dent_depth": math.nan}, ("max_dent_depth", "got nan")),
        ({"max_dent_depth": math.inf}, ("max_dent_depth", "got inf")),
        ({"model": np.eye(3)}, ("model", "4x4", "shape (3, 3)")),
        ({"model": np.eye(4)[:3]}, ("model", "4x4", "shape (3, 4)")),
        ({"model": "pose"}, ("model", "4x4", "'pose'")),
        ({"model": np.full((4, 4), math.nan)}, ("model", "finite", "nan at row 0, column 0")),
        ({"model": PERSPECTIVE}, ("model", "affine", "[0.0, 0.0, -1.0, 0.0]")),
        ({"model": FLAT}, ("model", "flatten", "determinant 0")),
        ({"model": MIRROR}, ("model", "mirror", "determinant -1")),
        ({"mesh": "bunny.obj"}, ("mesh", "dentdemo.Mesh or a trimesh.Trimesh", "got str")),
        ({"mesh": None}, ("mesh", "got NoneType")),
        ({"mesh": trimesh.Scene([trimesh.creation.box()])}, ("mesh", "trimesh.Scene", "1 ")),
        ({"ctx": None}, ("ctx", "moderngl.Context", "got NoneType")),
    ],
    ids=[
        "map_size_0",
        "map_size_8192",
        "map_size_15",
        "map_size_float",
        "map_size_text",
        "map_size_bool",
        "max_dent_depth_negative",
        "max_dent_depth_0",
        "max_dent_depth_nan",
        "max_dent_depth_inf",
        "model_3x3",
        "model_3x4",
        "model_text",
        "model_nan",
        "model_perspective",
        "model_flat",
        "model_mirror",
        "mesh_text",
        "mesh_none",
        "mesh_trimesh_scene",
        "ctx_none",
    ],
)
def test_surface_arguments_are_checked(gl, kwargs, fragments):
    args = {"ctx": gl.ctx, "mesh": PLATE, "map_size": 64, **kwargs}
    _raises(lambda: dentdemo.DentableSurface(**args), *fragments)


def test_model_is_checked_whenever_it_is_set_and_at_press(gl):
    plate = dentdemo.DentableSurface(gl.ctx, PLATE, 64)
    ball = _ball_above(gl.ctx)
    carver = dentdemo.Carver(gl.ctx)
    try:
        for bad, fragment in (
            (np.eye(3), "shape (3, 3)"),
            (np.full((4, 4), math.inf), "inf at row 0"),
            (MIRROR, "mirror"),
            (PERSPECTIVE, "affine"),
        ):
            _raises(lambda bad=bad: setattr(ball, "model", bad), "model", fragment)
        assert ball.model[1, 3] == 0.05  # a rejected pose leaves the one set before
        ball.model[1, 3] = math.nan  # edited in place: caught when pressed
        _raises(lambda: carver.press(plate, ball, DOWN, 0.002), "tool.model", "nan at row 1")
        assert not plate.heights().any()  # nothing was carved
        ball.model = np.eye(4)
        ball.model[1, 3] = 0.05
        assert carver.press(plate, ball, DOWN, 0.002)
    finally:
        for thing in (carver, ball, plate):
            thing.release()


def test_a_pose_edited_in_place_into_a_mirror_is_caught_at_press(gl):
    """A mirror turns the faces inside out: the carve would find no front face and dent
    nothing while press() returned True (so it was on main)."""
    plate = dentdemo.DentableSurface(gl.ctx, PLATE, 64)
    ball = _ball_above(gl.ctx)
    carver = dentdemo.Carver(gl.ctx)
    try:
        plate.model[2, 2] = -1.0
        _raises(lambda: carver.press(plate, ball, DOWN, 0.004), "target.model", "mirror")
    finally:
        for thing in (carver, ball, plate):
            thing.release()


@pytest.mark.parametrize(
    ("field", "value", "fragments"),
    [
        ("point", (0.0, 0.0), ("Contact point", "3 finite numbers", "(0.0, 0.0)")),
        ("point", (0, math.nan, 0), ("Contact point", "nan")),
        ("point", "here", ("Contact point", "'here'")),
        ("direction", (0, -1), ("Contact direction", "(0, -1)")),
        ("direction", (0, math.inf, 0), ("Contact direction", "inf")),
        ("direction", (0, 0, 0), ("Contact direction", "must not be zero", "(0, 0, 0)")),
        ("direction", [[0, -1, 0]], ("Contact direction", "[[0, -1, 0]]")),
    ],
)
def test_contact_arguments_are_checked_when_made_and_when_set(field, value, fragments):
    good = {"point": (0.0, 0.0, 0.0), "direction": (0.0, -1.0, 0.0)}
    _raises(lambda: dentdemo.Contact(**{**good, field: value}), *fragments)
    contact = dentdemo.Contact(**good)
    _raises(lambda: setattr(contact, field, value), *fragments)
    np.testing.assert_array_equal(getattr(contact, field), good[field])  # unchanged


@pytest.mark.parametrize(
    ("call", "fragments"),
    [
        (lambda c, t, b: c.press(t, b, DOWN, -0.001), ("depth", "got -0.001")),
        (lambda c, t, b: c.press(t, b, DOWN, math.nan), ("depth", "got nan")),
        (lambda c, t, b: c.press(t, b, DOWN, math.inf), ("depth", "got inf")),
        (lambda c, t, b: c.press(t, b, DOWN, "0.002"), ("depth", "got '0.002'")),
        (lambda c, t, b: c.press(t, b, DOWN, 0.002, -1), ("tool_depth", "got -1")),
        (lambda c, t, b: c.press(t, b, DOWN, 0.002, math.nan), ("tool_depth", "got nan")),
        (lambda c, t, b: c.press(t, t, DOWN, 0.002), ("same DentableSurface", "into itself")),
        (lambda c, t, b: c.press(t, BALL, DOWN, 0.002), ("tool", "DentableSurface", "got Mesh")),
        (lambda c, t, b: c.press(PLATE, b, DOWN, 0.002), ("target", "got Mesh")),
        (lambda c, t, b: c.press(t, b, ((0, 0, 0), (0, -1, 0)), 0.002), ("contact", "tuple")),
    ],
    ids=[
        "negative_depth",
        "nan_depth",
        "inf_depth",
        "text_depth",
        "negative_tool_depth",
        "nan_tool_depth",
        "pressed_into_itself",
        "tool_a_mesh",
        "target_a_mesh",
        "contact_a_tuple",
    ],
)
def test_press_arguments_are_checked_before_any_carve(gl, call, fragments):
    plate = dentdemo.DentableSurface(gl.ctx, PLATE, 64)
    ball = _ball_above(gl.ctx)
    carver = dentdemo.Carver(gl.ctx)
    try:
        _raises(lambda: call(carver, plate, ball), *fragments)
        assert not plate.heights().any() and not ball.heights().any()
    finally:
        for thing in (carver, ball, plate):
            thing.release()


def test_surfaces_of_another_context_are_refused(gl):
    other = create_headless()
    try:
        foreign = dentdemo.DentableSurface(other.ctx, PLATE, 64)
        gl.make_current()
        ball = _ball_above(gl.ctx)
        carver = dentdemo.Carver(gl.ctx)
        _raises(lambda: carver.press(foreign, ball, DOWN, 0.002), "target", "another")
        carver.release()
        ball.release()
    finally:
        other.release()
        gl.make_current()


def test_a_released_surface_or_carver_says_so(gl):
    plate = dentdemo.DentableSurface(gl.ctx, PLATE, 64)
    ball = _ball_above(gl.ctx)
    carver = dentdemo.Carver(gl.ctx)
    plate.release()
    plate.release()  # twice: nothing
    calls = {
        "heights()": lambda: plate.heights(),
        "height": lambda: plate.height,
        "normal": lambda: plate.normal,
        "map_size": lambda: plate.map_size,
        "max_dent_depth": lambda: plate.max_dent_depth,
        "set_heights()": lambda: plate.set_heights(np.zeros((64, 64), np.float32)),
        "set_bump_map()": lambda: plate.set_bump_map("bump.png", 0.001),
        "target": lambda: carver.press(plate, ball, DOWN, 0.002),
    }
    for name, call in calls.items():
        _raises(call, f"{name}: ", "DentableSurface (mesh 'plate') was released")
    _raises(lambda: carver.press(ball, plate, DOWN, 0.002), "tool: ", "was released")
    carver.release()
    carver.release()
    other = dentdemo.DentableSurface(gl.ctx, PLATE, 64)
    _raises(lambda: carver.press(other, ball, DOWN, 0.002), "this Carver was released")
    other.release()
    ball.release()


def test_prepare_checks_its_surfaces(gl):
    plate = dentdemo.DentableSurface(gl.ctx, PLATE, 64)
    carver = dentdemo.Carver(gl.ctx)
    _raises(lambda: carver.prepare(plate, "ball"), "surfaces[1]", "DentableSurface", "str")
    other = create_headless()
    try:
        foreign = dentdemo.DentableSurface(other.ctx, PLATE, 64)
        gl.make_current()
        _raises(lambda: carver.prepare(foreign), "surfaces[0]", "another moderngl context")
        plate.release()
        _raises(lambda: carver.prepare(plate), "prepare(): ", "was released")
        carver.release()
        _raises(lambda: carver.prepare(), "this Carver was released")
    finally:
        other.release()
        gl.make_current()


def test_a_prepared_surface_s_first_press_makes_nothing_and_dents_the_same(gl):
    """`Carver.prepare` makes the vertex arrays and index streams a surface's first presses
    would make, and changes no texel: a prepared pair's first press makes none, and dents both
    surfaces to the same bytes as the same press on a pair that was not prepared."""
    pairs = [(dentdemo.DentableSurface(gl.ctx, PLATE, 64), _ball_above(gl.ctx)) for _ in range(2)]
    carver = dentdemo.Carver(gl.ctx)
    try:
        prepared = pairs[0]
        carver.prepare(*prepared)
        assert not any(s.heights().any() for s in prepared)  # no texel written
        counts = [(len(s._gpu._vaos), len(s._gpu._subsets)) for s in prepared]
        assert all(vaos > 1 and streams > 0 for vaos, streams in counts)
        for plate, ball in pairs:
            assert carver.press(plate, ball, DOWN, 0.004, 0.002)
        assert [(len(s._gpu._vaos), len(s._gpu._subsets)) for s in prepared] == counts
        (plate0, ball0), (plate1, ball1) = pairs
        assert plate0.heights().min() < -0.003 and ball0.heights().min() < -0.001
        assert np.array_equal(plate0.heights(), plate1.heights())
        assert np.array_equal(ball0.heights(), ball1.heights())
    finally:
        carver.release()
        for surface in (s for pair in pairs for s in pair):
            surface.release()


def test_a_trimesh_keeps_its_uvs_maps_back_and_takes_a_dent(gl):
    """A host's own trimesh.Trimesh with a unique atlas: taken as is (no re-atlas, no warning),
    every vertex names the trimesh vertex it copies, and a 3 mm press leaves 3 mm."""
    pos, faces, uv = grid(8, side=0.4)
    pos -= (0.2, 0.0, -0.2)  # centred on the origin, facing +Y
    host = trimesh.Trimesh(pos, faces, visual=trimesh.visual.TextureVisuals(uv=uv), process=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plate = dentdemo.DentableSurface(gl.ctx, host, 128)
    mesh = plate.mesh
    np.testing.assert_array_equal(mesh.positions, pos.astype(np.float32)[mesh.source_vertex])
    np.testing.assert_allclose(mesh.uvs, uv[mesh.source_vertex], atol=1e-7)
    ball = _ball_above(gl.ctx)
    carver = dentdemo.Carver(gl.ctx)
    try:
        assert carver.press(plate, ball, DOWN, 0.003)
        assert float(-plate.heights().min()) == pytest.approx(0.003, rel=0.03)
    finally:
        for thing in (carver, ball, plate):
            thing.release()


def test_a_trimesh_without_uvs_is_reatlased_and_maps_back(gl):
    host = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    with pytest.warns(UserWarning, match="re-atlasing"):
        surface = dentdemo.DentableSurface(gl.ctx, host, 64)
    mesh = surface.mesh
    np.testing.assert_array_equal(
        mesh.positions, np.asarray(host.vertices, np.float32)[mesh.source_vertex]
    )
    surface.release()


def test_every_entry_point_s_bad_argument_is_a_value_error(gl, tmp_path):
    """The README's promise, at the entry points it did not hold for on ee6049f: export_gltf to
    x.obj raised DentdemoError, an unknown look ConfigError, load_mesh of a missing file
    DentdemoError and shape_mesh of a non-shape TypeError, none of them a ValueError; a look out
    of range was written (roughness 5) or crashed. A missing mesh file is also a
    FileNotFoundError. Nothing is written."""
    (tmp_path / "words.obj").write_text("these are words, not vertices\n")
    plate = dentdemo.DentableSurface(gl.ctx, PLATE, 64)
    sheared = dentdemo.DentableSurface(gl.ctx, PLATE, 64)
    sheared.model = np.array([[1.0, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    glb = tmp_path / "a.glb"
    red = dentdemo.Appearance(base_colour="red")  # type: ignore[arg-type]
    rough, shiny = dentdemo.Appearance(roughness=5.0), dentdemo.Appearance(surface="shiny")
    cases = [
        (lambda: dentdemo.load_mesh(tmp_path / "absent.obj"), ("absent.obj", "cannot load mesh")),
        (lambda: dentdemo.load_mesh(tmp_path / "words.obj"), ("words.obj", "no triangles")),
        (lambda: dentdemo.load_mesh(tmp_path), (str(tmp_path), "cannot load mesh")),
        (lambda: dentdemo.load_mesh(3), ("path", "int")),
        (lambda: dentdemo.load_mesh(tmp_path / "words.obj", -1.0), ("scale", "-1.0")),
        (lambda: dentdemo.shape_mesh("ball"), ("shape", "Sphere", "str 'ball'")),
        (lambda: dentdemo.export_gltf(tmp_path / "x.obj", [plate]), ("path", "x.obj", ".glb")),
        (lambda: dentdemo.export_gltf(None, [plate]), ("path", "None")),
        (lambda: dentdemo.export_gltf(glb, plate), ("surfaces", "DentableSurface")),
        (lambda: dentdemo.export_gltf(glb, [plate], looks=["unobtainium"]), ("looks[0]",)),
        (lambda: dentdemo.export_gltf(glb, [plate], looks=[3]), ("looks[0]", "int")),
        (
            lambda: dentdemo.export_gltf(glb, [plate], looks=[red]),
            ("looks[0].base_colour", "'red'"),
        ),
        (lambda: dentdemo.export_gltf(glb, [plate], looks=[rough]), ("looks[0].roughness", "5.0")),
        (
            lambda: dentdemo.export_gltf(glb, [plate], looks=[shiny]),
            ("looks[0].surface", "'shiny'"),
        ),
        (lambda: dentdemo.export_gltf(glb, [plate, sheared]), ("surfaces[1].model", "shear")),
    ]
    for call, fragments in cases:
        _raises(call, *fragments)
    with pytest.raises(FileNotFoundError):
        dentdemo.load_mesh(tmp_path / "absent.obj")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["words.obj"]
    for surface in (plate, sheared):
        surface.release()
