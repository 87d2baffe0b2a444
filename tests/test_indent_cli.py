"""`dentdemo indent` end to end."""

import json

import numpy as np
import pytest
from PIL import Image

from cli_helpers import dentdemo


@pytest.mark.slow
def test_indent_reports_the_cap_error(tmp_path):
    out = tmp_path / "press"
    result = dentdemo(
        "indent",
        "--tool",
        "sphere",
        "--tool-size",
        "0.05",
        "--target",
        "plate",
        "--target-size",
        "1",
        "--depth",
        "0.01",
        "--map-size",
        "1024",
        "--out",
        str(out),
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["cap"]["rms_error_rel"] < 0.02
    assert summary["max_depth_m"] == pytest.approx(0.01, rel=0.01)
    target = np.load(out / "target_height.npy")
    assert target.dtype == np.float32 and target.shape == (1024, 1024)
    assert np.load(out / "tool_height.npy").max() == 0.0
    png = Image.open(out / "target_height.png")
    assert png.mode.startswith("I") and png.size == (1024, 1024)
    grey = np.asarray(png)
    assert grey.max() == 65535 and grey.min() < 65535
    assert Image.open(out / "target_normal.png").size == (1024, 1024)
    # Footprint radius matches sqrt(2 R d - d^2) = 30 mm within 1.5 texels.
    assert summary["footprint_radius_m"] == pytest.approx(0.03, abs=1.5 / 1024)


@pytest.mark.parametrize(
    "args,fragment",
    [
        (["--depth", "-1"], "--depth"),
        (["--depth", "nan"], "--depth"),
        (["--depth", "0.01", "--tool-size", "0"], "--tool-size"),
        (["--depth", "0.01", "--map-size", "3"], "--map-size"),
        (["--depth", "0.01", "--normal", "0", "0", "0"], "--normal"),
    ],
)
@pytest.mark.slow
def test_indent_bad_arguments(tmp_path, args, fragment):
    result = dentdemo("indent", *args, "--out", str(tmp_path))
    assert result.returncode != 0
    assert fragment in result.stderr and len(result.stderr.strip().splitlines()) == 1
