"""A mesh's own base-colour texture (OBJ/MTL map_Kd, glTF baseColorTexture) is drawn where its
texture coordinates put it, in the sandbox and headless."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from dentdemo.app.controller import DemoController
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene

QUADRANTS = {  # (u half, v half) -> sRGB colour
    (0, 0): (220, 30, 30),
    (1, 0): (30, 30, 220),
    (0, 1): (30, 200, 30),
    (1, 1): (230, 220, 30),
}


def _textured_quad(folder):
    """A 0.4 m square at y = 0 (x, z in [0, 0.4]) with u along x, v along z, and a texture whose
    quadrants have four colours; written as OBJ + MTL + PNG and as glTF (GLB)."""
    image = np.zeros((64, 64, 3), np.uint8)
    for (iu, iv), colour in QUADRANTS.items():
        rows = slice(0, 32) if iv == 1 else slice(32, 64)  # image rows run top-down: v = 1 first
        image[rows, iu * 32 : iu * 32 + 32] = colour
    Image.fromarray(image).save(folder / "quad.png")
    (folder / "quad.mtl").write_text("newmtl m\nKd 1 1 1\nmap_Kd quad.png\n")
    (folder / "quad.obj").write_text(
        "mtllib quad.mtl\nv 0 0 0\nv 0.4 0 0\nv 0.4 0 0.4\nv 0 0 0.4\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl m\nf 1/1 3/3 2/2\nf 1/1 4/4 3/3\n"
    )
    import trimesh

    trimesh.load(folder / "quad.obj", force="mesh", process=False).export(folder / "quad.glb")


def _scene(folder, mesh_file: str):
    path = folder / f"scene_{mesh_file}.toml"
    path.write_text(
        "[camera]\neye = [0.2, 0.9, 0.25]\ntarget = [0.2, 0.0, 0.2]\nfov_deg = 40\n"
        '[[body]]\nid = "ground"\nshape = "plane"\nmaterial = "oak"\n'
        f'[[body]]\nid = "quad"\nshape = "mesh"\nmesh = "{mesh_file}"\nmaterial = "clay"\n'
        "position = [0.0, 0.01, 0.0]\nstatic = true\ntexels_per_metre = 256\n"
    )
    return path


@pytest.mark.parametrize("mesh_file", ["quad.obj", "quad.glb"])
def test_mesh_texture_is_drawn_where_its_uvs_say(gl, tmp_path, mesh_file):
    _textured_quad(tmp_path)
    lib = load_materials()
    app = DemoController(
        gl, load_scene(_scene(tmp_path, mesh_file), lib), lib, (320, 240), quality="high"
    )
    try:
        app.sim.step()
        app.view.render()
        image = app.view.renderer.read_rgb().astype(int)
        for (iu, iv), colour in QUADRANTS.items():
            centre = np.array([0.1 + 0.2 * iu, 0.01, 0.1 + 0.2 * iv])
            x, y = app.view.camera.project(centre, app.view.renderer.aspect, (320, 240))[0]
            pixel = image[int(y), int(x)]
            # The shaded colour keeps the texture's hue: its strongest channel(s) win.
            strongest = np.argsort(colour)[-1]
            weakest = np.argsort(colour)[0]
            assert pixel[strongest] > pixel[weakest] + 40, (iu, iv, pixel, colour)
    finally:
        app.close()
