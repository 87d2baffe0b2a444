"""The code style of DESIGN.md: ruff at line length 100, formatted, and shaders that start with
`#version 330 core`."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _ruff(*args: str) -> subprocess.CompletedProcess:
    """ruff, of the test extra (pip install -e .[test]): missing, the style tests fail."""
    return subprocess.run(
        [sys.executable, "-m", "ruff", *args], capture_output=True, text=True, cwd=ROOT
    )


def test_ruff_lint():
    result = _ruff("check", "src", "tests")
    assert result.returncode == 0, result.stdout + result.stderr


def test_ruff_format():
    result = _ruff("format", "--check", "src", "tests")
    assert result.returncode == 0, result.stdout + result.stderr


def test_every_shader_stage_starts_with_version_330_core():
    stages = [p for p in (ROOT / "shaders").rglob("*") if p.suffix in (".vert", ".frag", ".geom")]
    assert stages
    for path in stages:
        assert path.read_text().splitlines()[0] == "#version 330 core", path
