"""Draws docs/carve_passes.png: what each carve pass produces for one press (a 3 cm ball 4 mm
into a plate, square-on). Run from the repository root:
    .venv/bin/python docs/carve_figure.py
Reads the scratch buffers back, which the carve itself never does."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody, Carver
from dentdemo.carve.shapes import Shape
from dentdemo.carve.surface import create_maps
from dentdemo.gl.context import create_headless
from dentdemo.gpu.mesh import GpuMesh

PANEL = 256


def _body(gl, shape: Shape, size: int, position=(0.0, 0.0, 0.0)) -> CarveBody:
    gpu = GpuMesh(gl, shape.mesh(2))
    body = CarveBody(gpu, create_maps(gl, gpu, size, 0.05))
    body.model[:3, 3] = position
    return body


def _panel(rgb: np.ndarray, title: str, aspect: float = 1.0) -> Image.Image:
    """An image (row 0 at the bottom) fitted into the panel; `aspect` is its width over height
    in metres."""
    img = Image.fromarray(np.ascontiguousarray(rgb[::-1]).astype(np.uint8))
    w, h = (PANEL, round(PANEL / aspect)) if aspect >= 1 else (round(PANEL * aspect), PANEL)
    img = img.resize((w, h), Image.Resampling.NEAREST)
    framed = Image.new("RGB", (PANEL, PANEL + 22), "white")
    framed.paste(img, ((PANEL - w) // 2, 22 + (PANEL - h) // 2))
    ImageDraw.Draw(framed).text((4, 4), title, fill="black")
    return framed


def main() -> None:
    gl = create_headless()
    plate = _body(gl, Shape("plate", (0.25,)), 512)
    ball = _body(gl, Shape("sphere", (0.03,)), 256, (0.0, 0.03, 0.0))
    contact = ContactFrame(np.zeros(3), np.array([0.0, -1.0, 0.0]))
    carver = Carver(gl)
    carver.measure_passes(plate, ball, contact, 0.004)  # passes 1-3, to read their buffers
    job = (
        carver.last_jobs[0] if carver.last_jobs else carver.plan(plate, ball, contact, 0.004, 0)[0]
    )
    w, h = job.camera.resolution
    slot = carver.slot(0)
    address = gl.read_region(slot.address_fbo, (0, 0, w, h), 4, 0)
    tool = gl.read_region(slot.peel_fbo, (0, 0, w, h), 2, 0)  # (depth m, coverage)
    carver.carve(plate, ball, contact, 0.004)
    height = gl.read(plate.maps.height)[:, :, 0]
    normal = gl.read(plate.maps.normal)[:, :, :3]
    # Crop the maps to the texels under the camera.
    rows, cols = np.nonzero(height < 0)
    r0, r1 = max(rows.min() - 8, 0), rows.max() + 9
    c0, c1 = max(cols.min() - 8, 0), cols.max() + 9
    seen = address[:, :, 0] >= 0
    uv = np.where(seen[..., None], np.dstack([address[:, :, 0], address[:, :, 1]]), 0.0)
    uv_rgb = np.dstack([(uv[..., 0] * 40) % 1, (uv[..., 1] * 40) % 1, ~seen * 0.6]) * 255
    reach = tool[:, :, 1] > 0.5
    depth = np.where(reach, tool[:, :, 0], np.nan)
    lo, hi = np.nanmin(depth), np.nanmax(depth)
    tool_rgb = np.where(reach, (depth - lo) / max(hi - lo, 1e-9), 0.0)[..., None] * [255, 200, 120]
    crop = -height[r0:r1, c0:c1] / max(-height.min(), 1e-9)
    height_rgb = np.dstack([crop * 255, crop * 120, 60 + 0 * crop])
    aspect = job.camera.half_extent[0] / job.camera.half_extent[1]
    panels = [
        _panel(uv_rgb, f"2 address map ({w}x{h} px)", aspect),
        _panel(tool_rgb, "3 peeled tool depth", aspect),
        _panel(height_rgb, "4 gathered height (crop)"),
        _panel(normal[r0:r1, c0:c1], "5 rebuilt normals (crop)"),
    ]
    out = Image.new("RGB", (4 * PANEL + 30, PANEL + 22), "white")
    for i, p in enumerate(panels):
        out.paste(p, (i * (PANEL + 10), 0))
    path = Path(__file__).with_name("carve_passes.png")
    out.save(path)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
