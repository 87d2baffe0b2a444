"""Meshes a host brings: their own texture coordinates are kept (OBJ and glTF, with or without a
material, Draco-compressed or not), every vertex maps back to the host's (`Mesh.source_vertex`),
undecodable glTF is a clear error, and bad arrays are named. Expected values come from the
arrays the test wrote."""

from __future__ import annotations

import json
import struct
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

import dentdemo
from dentdemo.errors import ArgumentError, DentdemoError
from dentdemo.mesh.loader import check_uvs, load_mesh, mesh_from_triangles
from dentdemo.mesh.mesh import Mesh
from mesh_helpers import glb, gltf, grid


def _cube() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A unit cube of 8 shared corners (its hard edges split every corner into 3 vertices)
    with a per-corner uv that is not a unique atlas (all 8 corners over one square)."""
    box = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    uv = (box.vertices[:, :2] > 0).astype(float) * 0.8 + 0.1
    return np.asarray(box.vertices), np.asarray(box.faces), uv


def _write_glb(path: Path, doc: dict, blob: bytes) -> Path:
    path.write_bytes(glb(doc, blob))
    return path


def _load_quietly(path: Path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mesh = load_mesh(path)
    return mesh, [str(w.message) for w in caught]


def _matches_file(mesh, pos: np.ndarray, uv: np.ndarray) -> None:
    """Each vertex of `mesh` is the file's vertex `source_vertex` with that vertex's own uv."""
    np.testing.assert_array_equal(mesh.positions, pos.astype(np.float32)[mesh.source_vertex])
    np.testing.assert_allclose(mesh.uvs, uv[mesh.source_vertex], atol=1e-6)


@pytest.mark.parametrize("material", [False, True], ids=["no_material", "material"])
def test_glb_keeps_its_own_uvs_with_or_without_a_material(tmp_path, material):
    pos, faces, uv = grid()
    path = _write_glb(tmp_path / "grid.glb", *gltf(pos, faces, uv, material))
    mesh, caught = _load_quietly(path)
    assert caught == []  # no "texture coordinates are missing; re-atlasing"
    # glTF puts v = 0 at the image's top; the mesh's v = 0 is texture row 0 (OpenGL).
    _matches_file(mesh, pos, np.stack([uv[:, 0], 1.0 - uv[:, 1]], 1))
    assert len(mesh.indices) == len(faces)


def test_gltf_with_an_external_buffer_keeps_its_uvs(tmp_path):
    pos, faces, uv = grid()
    doc, blob = gltf(pos, faces, uv, material=False)
    doc["buffers"][0]["uri"] = "grid.bin"
    (tmp_path / "grid.bin").write_bytes(blob)
    (tmp_path / "grid.gltf").write_text(json.dumps(doc))
    mesh, caught = _load_quietly(tmp_path / "grid.gltf")
    assert caught == []
    _matches_file(mesh, pos, np.stack([uv[:, 0], 1.0 - uv[:, 1]], 1))


@pytest.mark.parametrize("mtl", [False, True], ids=["no_mtl", "mtl"])
def test_obj_keeps_its_own_uvs_with_or_without_a_material(tmp_path, mtl):
    pos, faces, uv = grid()
    head = "mtllib m.mtl\nusemtl paint\n" if mtl else ""
    if mtl:
        (tmp_path / "m.mtl").write_text("newmtl paint\nKd 0.8 0.2 0.1\n")
    text = head + "".join(f"v {x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in pos)
    text += "".join(f"vt {a:.17g} {b:.17g}\n" for a, b in uv)
    text += "".join(f"f {a}/{a} {b}/{b} {c}/{c}\n" for a, b, c in faces + 1)
    (tmp_path / "grid.obj").write_text(text)
    mesh, caught = _load_quietly(tmp_path / "grid.obj")
    assert caught == []
    _matches_file(mesh, pos, uv)


def _draco_glb(tmp_path: Path) -> tuple[Path, np.ndarray, np.ndarray]:
    """A real Draco-compressed GLB (trimesh's exporter, DracoPy's encoder, 14-bit positions) of
    the grid with its uvs: path, positions, uvs."""
    pos, faces, uv = grid(8)
    mesh = trimesh.Trimesh(pos, faces, visual=trimesh.visual.TextureVisuals(uv=uv), process=False)
    path = tmp_path / "draco.glb"
    path.write_bytes(mesh.export(file_type="glb", extension_draco=True))
    return path, pos, uv


def _json_of(path: Path) -> dict:
    data = path.read_bytes()
    return json.loads(data[20 : 20 + struct.unpack_from("<I", data, 12)[0]])


def test_draco_compressed_glb_is_decoded_with_its_uvs(tmp_path):
    path, pos, uv = _draco_glb(tmp_path)
    doc = _json_of(path)
    assert doc["extensionsRequired"] == ["KHR_draco_mesh_compression"]
    assert all("bufferView" not in a for a in doc["accessors"])  # no uncompressed fallback
    mesh, caught = _load_quietly(path)
    assert caught == []
    # Positions within Draco's 14-bit quantisation of the 0.2 m extent: 0.2 * 2^-15 m.
    error = np.abs(mesh.positions - pos[mesh.source_vertex]).max()
    assert error <= 0.2 * 2.0**-15 + 1e-7
    np.testing.assert_allclose(mesh.uvs, uv[mesh.source_vertex], atol=1e-4)
    assert mesh.surface_area() == pytest.approx(0.04, rel=1e-3)


def test_draco_without_its_decoder_is_a_clear_error(tmp_path, monkeypatch):
    """A broken install (DracoPy missing): the message names the extension and the package,
    not "every triangle has no area"."""
    path, _, _ = _draco_glb(tmp_path)
    monkeypatch.setitem(sys.modules, "DracoPy", None)  # `import DracoPy` raises ImportError
    with pytest.raises(DentdemoError, match="KHR_draco_mesh_compression") as info:
        load_mesh(path)
    assert "draco.glb" in str(info.value) and "DracoPy" in str(info.value)


def test_corrupt_draco_data_is_a_clear_error(tmp_path):
    pos, faces, uv = grid()
    doc, blob = gltf(pos, faces, uv, material=False)
    doc["extensionsUsed"] = doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    doc["meshes"][0]["primitives"][0]["extensions"] = {
        "KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}
    }
    for accessor in doc["accessors"]:
        del accessor["bufferView"]  # buffer view 0 now holds plain floats, not a Draco stream
    path = _write_glb(tmp_path / "corrupt.glb", doc, blob)
    with pytest.raises(DentdemoError, match="corrupt.glb: its KHR_draco_mesh_compression data"):
        load_mesh(path)


def test_meshopt_compressed_glb_is_a_clear_error(tmp_path):
    pos, faces, uv = grid()
    doc, blob = gltf(pos, faces, uv, material=False)
    doc["extensionsUsed"] = doc["extensionsRequired"] = ["EXT_meshopt_compression"]
    path = _write_glb(tmp_path / "meshopt.glb", doc, blob)
    with pytest.raises(DentdemoError, match="meshopt.glb: .*EXT_meshopt_compression"):
        load_mesh(path)


def test_host_vertices_map_back_through_seams_creases_and_a_reatlas():
    """A cube of 8 shared corners: its hard edges split each corner into 3 vertices, and its
    uvs are re-atlased; every vertex still names the host corner it copies."""
    pos, faces, uv = _cube()
    with pytest.warns(UserWarning, match="re-atlasing"):
        mesh = mesh_from_triangles(pos, faces, uv)
    assert len(mesh.positions) > len(pos)  # split
    np.testing.assert_array_equal(mesh.positions, pos.astype(np.float32)[mesh.source_vertex])
    assert set(mesh.source_vertex.tolist()) == set(range(len(pos)))
    # The host's per-vertex data carries over: here, which octant each corner is in.
    octant = (pos > 0) @ [1, 2, 4]
    assert np.array_equal(octant[mesh.source_vertex], (mesh.positions > 0) @ [1, 2, 4])
    # Each triangle of the new mesh is a host triangle with the same corners.
    host = {tuple(sorted(f)) for f in faces.tolist()}
    ours = {tuple(sorted(mesh.source_vertex[f])) for f in mesh.indices.astype(int).tolist()}
    assert ours == host


def test_valid_uvs_are_kept_and_vertices_map_back():
    pos, faces, uv = grid()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no re-atlas
        mesh = mesh_from_triangles(pos, faces, uv)
    _matches_file(mesh, pos, uv)
    assert check_uvs(mesh.uvs, mesh.indices).ok


@pytest.mark.parametrize(
    ("positions", "indices", "uvs", "fragment"),
    [
        (
            np.zeros((3, 2)),
            [[0, 1, 2]],
            None,
            "positions must be an (n, 3) array, got shape (3, 2)",
        ),
        (np.eye(3) * np.nan, [[0, 1, 2]], None, "positions are not finite"),
        ("abc", [[0, 1, 2]], None, "positions must be an (n, 3) array, got 'abc'"),
        (np.eye(3), [[0, 1, 3]], None, "indices must lie in [0, 2], got 3"),
        (np.eye(3), [[0, 1, -1]], None, "indices must lie in [0, 2], got -1"),
        (np.eye(3), [[0.0, 1.0, 2.0]], None, "indices must be (m, 3) integers, got float64"),
        (np.eye(3), [[0, 1]], None, "indices must be (m, 3) integers"),
        (np.eye(3), [[0, 1, 2]], np.zeros((2, 2)), "uvs must have one row per position (3), got 2"),
        (np.eye(3), [[0, 1, 2]], np.zeros((3, 3)), "uvs must be an (n, 2) array"),
        (np.eye(3), [[0, 1, 2]], np.full((3, 2), np.inf), "uvs are not finite"),
    ],
)
def test_mesh_from_triangles_names_a_bad_array(positions, indices, uvs, fragment):
    with pytest.raises(ValueError) as info:
        mesh_from_triangles(positions, indices, uvs, name="host")
    assert isinstance(info.value, ArgumentError)
    assert str(info.value).startswith("host: ") and fragment in str(info.value)


@pytest.mark.parametrize(
    ("field", "value", "fragment"),
    [
        ("positions", np.zeros((4, 2)), "Mesh positions must be an (n, 3) array"),
        ("normals", np.zeros((3, 3)), "Mesh normals must have one row per position (4), got 3"),
        ("uvs", np.full((4, 2), np.nan), "Mesh uvs must be an (n, 2) array of finite numbers"),
        ("indices", [[0, 1, 4]], "Mesh indices must lie in [0, 3], got 4"),
        ("texture_uvs", np.zeros((4, 3)), "Mesh texture_uvs must be an (n, 2) array"),
    ],
)
def test_a_mesh_made_directly_names_a_bad_array(field, value, fragment):
    quad = {
        "name": "quad",
        "positions": np.array([[0, 0, 0], [1, 0, 0], [1, 0, -1], [0, 0, -1]], float),
        "normals": np.tile([0.0, 1.0, 0.0], (4, 1)),
        "uvs": np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float),
        "indices": [[0, 1, 2], [0, 2, 3]],
    }
    with pytest.raises(ArgumentError) as info:
        Mesh(**{**quad, field: value})
    assert fragment in str(info.value)


@pytest.mark.parametrize("scale", [0.0, -1.0, float("nan"), "big"])
def test_load_mesh_names_a_bad_scale(tmp_path, scale):
    path = tmp_path / "m.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(
        ArgumentError, match=f"m.obj: scale must be a positive finite number, got {scale!r}"
    ):
        load_mesh(path, scale)


@pytest.mark.parametrize(
    "child,said",
    [
        ("import os, signal\nos.kill(os.getpid(), signal.SIGSEGV)\n", "xatlas crashed (SIGSEGV)"),
        ("raise RuntimeError('no charts fit')\n", "xatlas failed (RuntimeError: no charts fit)"),
    ],
    ids=["crash", "error"],
)
def test_an_atlas_that_crashes_or_fails_is_one_line_naming_the_mesh(
    tmp_path, monkeypatch, child, said
):
    """xatlas runs in a process of its own: where it dies of a signal (as xatlas-python does on
    some large meshes: jpcy/xatlas#151) or raises, loading a mesh that needs an atlas is one
    ArgumentError that names the file, its triangle count and what happened, and this process
    goes on; a stand-in script plays xatlas here. The real child re-atlases the same mesh."""
    from dentdemo.mesh import loader

    pos, faces, _ = _cube()
    path = tmp_path / "needs_atlas.obj"
    trimesh.Trimesh(pos, faces, process=False).export(path)  # no texture coordinates
    stand_in = tmp_path / "child.py"
    stand_in.write_text(child)
    with monkeypatch.context() as patch:
        patch.setattr(loader, "ATLAS_CHILD", stand_in)
        with pytest.raises(ArgumentError) as caught:
            _load_quietly(path)
    message = str(caught.value)
    assert "\n" not in message and str(path) in message and said in message
    assert f"its {len(faces)} triangles" in message
    mesh, said_warnings = _load_quietly(path)  # the real xatlas, in its own process
    assert len(mesh.indices) == len(faces) and check_uvs(mesh.uvs, mesh.indices).ok
    assert any("re-atlasing" in w for w in said_warnings)


def test_an_atlas_without_an_interpreter_to_run_it_is_one_line(tmp_path, monkeypatch):
    """Where no Python can be started for xatlas's process (an embedded interpreter has no
    `sys.executable` to run), loading a mesh that needs an atlas is one ArgumentError naming the
    file, not an OSError from deep in the loader."""
    pos, faces, _ = _cube()
    path = tmp_path / "needs_atlas.obj"
    trimesh.Trimesh(pos, faces, process=False).export(path)
    monkeypatch.setattr(sys, "executable", str(tmp_path / "no-python-here"))
    with pytest.raises(ArgumentError) as caught:
        _load_quietly(path)
    message = str(caught.value)
    assert str(path) in message and "xatlas could not be started" in message


def test_a_triangle_with_no_uv_area_is_kept_by_a_reatlas(gl, tmp_path):
    """A folded 4 x 4 grid whose triangle 13 has its three uvs on one line (issue 41, item 10:
    Suzanne's triangle 1882 went missing from the mesh and its exports, silently, on ee6049f).
    The one warning names it; the mesh is re-atlased and keeps all 32 triangles, each with area
    in the atlas, each the caller's triangle (by source_vertex); a surface made of it draws and
    exports all 32."""
    pos, faces, uv = grid()
    pos[:, 1] = 0.05 * np.sin(pos[:, 0] * 20.0)  # folded: no two triangles share a plane
    soup = pos[faces].reshape(-1, 3)  # each triangle its own corners
    soup_faces = np.arange(len(soup)).reshape(-1, 3)
    soup_uv = uv[faces].reshape(-1, 2)
    bad = 13
    a, b = soup_uv[3 * bad], soup_uv[3 * bad + 1]
    soup_uv[3 * bad + 2] = (a + b) / 2  # on the line through the other two
    with pytest.warns(UserWarning) as caught:
        mesh = mesh_from_triangles(soup, soup_faces, soup_uv, name="folded")
    assert len(caught) == 1
    assert str(caught[0].message) == (
        "folded: texture coordinates are flat for triangle 13 (no area in the atlas); re-atlasing"
    )
    assert len(mesh.indices) == len(faces) == 32
    t = mesh.uvs.astype(np.float64)[mesh.indices]
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    assert (np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) > 1e-8).all()
    ours = sorted(tuple(sorted(f)) for f in mesh.source_vertex[mesh.indices].tolist())
    assert ours == sorted(tuple(sorted(f)) for f in soup_faces.tolist())
    surface = dentdemo.DentableSurface(gl.ctx, mesh, 64)
    try:
        assert len(surface.mesh.indices) == 32
        glb = dentdemo.export_gltf(tmp_path / "folded.glb", [surface]).read_bytes()
        (length,) = struct.unpack("<I", glb[12:16])
        document = json.loads(glb[20 : 20 + length])
        primitive = document["meshes"][0]["primitives"][0]
        assert document["accessors"][primitive["indices"]]["count"] == 3 * 32
    finally:
        surface.release()
