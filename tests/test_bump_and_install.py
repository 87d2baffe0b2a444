"""Authored bump maps as start heights, and a non-editable install that runs."""

import json
import shutil
import subprocess
import sys
import zipfile
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
    # Two levels: the face at 2 mm, the tool's stripes 1 mm deeper.
    assert np.isclose(dented, -0.002, atol=2e-5).mean() > 0.5
    assert np.isclose(dented, -0.003, atol=2e-5).mean() > 0.05
    assert json.loads((out / "summary.json").read_text())["max_depth_m"] == pytest.approx(
        0.003, abs=2e-5
    )


def test_wheel_carries_shaders_and_assets_and_runs_installed(tmp_path):
    wheels = tmp_path / "wheels"
    # Build from a copy without the in-tree build/ folder, whose stale files (modules since
    # moved or deleted) setuptools would otherwise put into the wheel.
    source = tmp_path / "source"
    shutil.copytree(
        ROOT,
        source,
        ignore=shutil.ignore_patterns(
            "build", "dist", ".venv", ".git", "*.egg-info", "__pycache__", ".*cache", ".old"
        ),
    )
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(source)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert build.returncode == 0, build.stderr[-2000:]
    wheel = next(wheels.glob("dentdemo-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    for shader in (ROOT / "shaders").rglob("*"):
        if shader.is_file():
            assert f"dentdemo/shaders/{shader.relative_to(ROOT / 'shaders').as_posix()}" in names
    assert (
        "dentdemo/assets/materials.toml" in names
        and "dentdemo/assets/scenes/ball_drop.toml" in names
    )
    target = tmp_path / "site"
    install = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--no-deps",
            "-q",
            "--target",
            str(target),
            str(wheel),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert install.returncode == 0, install.stderr[-2000:]
    # Run from the installed copy only (no src/ on the path): shaders compile and a press runs.
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]);"
        "import dentdemo.resources as r, dentdemo.cli as cli;"
        "assert str(r.shaders_dir()).startswith(sys.argv[1]), r.shaders_dir();"
        "sys.exit(cli.main(['indent', '--depth', '0.005', '--map-size', '128',"
        " '--out', sys.argv[2]]))"
    )
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    run = subprocess.run(
        [sys.executable, "-I", "-c", code, str(target), str(tmp_path / "press")],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    assert (
        json.loads((tmp_path / "press" / "summary.json").read_text())["cap"]["rms_error_rel"] < 0.02
    )
