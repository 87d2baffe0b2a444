"""Authored bump maps as start heights (the installed wheel: tests/test_install.py)."""

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from cli_helpers import dentdemo
from dentdemo.app.simulation import Simulation
from dentdemo.errors import ConfigError
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]

SCENE = """
[[body]]
id = "plate"
shape = "plate"
side = 0.5
material = "steel"
static = true
texels_per_metre = 256
bump_map = "bumps.png"
bump_height_m = 0.003
"""


def _stripes(path: Path, size: int = 64) -> None:
    img = np.zeros((size, size), np.uint8)
    img[:, ::8] = 255  # white columns every 8 pixels
    Image.fromarray(img).save(path)


def test_scene_bump_map_is_the_start_height(gl, tmp_path):
    _stripes(tmp_path / "bumps.png")
    (tmp_path / "scene.toml").write_text(SCENE)
    lib = load_materials()
    sim = Simulation(gl, load_scene(tmp_path / "scene.toml", lib), lib)
    maps = sim.bodies["plate"].maps
    height = gl.read(maps.height)[:, :, 0]
    assert height.shape == (128, 128)
    assert height.max() == pytest.approx(0.003, rel=1e-3) and height.min() >= 0.0
    # Columns, not rows: the pattern varies along u only.
    assert np.ptp(height, axis=0).max() < 1e-6 and np.ptp(height, axis=1).min() > 0.001
    normal = gl.read(maps.normal)
    assert normal[..., 0].std() > 5  # the normals see the bumps (tilted along u)
    sim.close()


def test_scene_bump_map_missing_file_is_an_error(tmp_path):
    (tmp_path / "scene.toml").write_text(SCENE)
    with pytest.raises(
        ConfigError, match=r"\[body.plate\] key 'bump_map' = 'bumps.png': no such file"
    ):
        load_scene(tmp_path / "scene.toml", load_materials())


@pytest.mark.slow
def test_indent_tool_pattern_png(tmp_path):
    _stripes(tmp_path / "p.png", 256)
    out = tmp_path / "out"
    result = dentdemo(
        "indent",
        "--tool",
        "box",
        "--tool-size",
        "0.1",
        "--depth",
        "0.002",
        "--tool-pattern",
        str(tmp_path / "p.png"),
        "--pattern-height",
        "0.001",
        "--map-size",
        "256",
        "--out",
        str(out),
    )
    assert result.returncode == 0, result.stderr
    target = np.load(out / "target_height.npy")
    dented = target[target < -1e-6]
    # The face at 2 mm, the tool's stripes up to 1 mm deeper. The tool's surface is its height
    # map bilinear between texel centres (as drawn): a one-pixel stripe is a tent one texel
    # wide either side, whose top only a target texel centre on the tool texel's centre meets.
    assert np.isclose(dented, -0.002, atol=2e-5).mean() > 0.5
    assert dented.min() >= -0.003 - 2e-5  # never below the bump's top
    assert (dented < -0.0022).mean() > 0.05  # the stripes are printed
    deepest = json.loads((out / "summary.json").read_text())["max_depth_m"]
    assert 0.0024 < deepest <= 0.003 + 2e-5
