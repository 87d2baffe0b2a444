"""A deterministic press with no physics (the Brinell test of the method): a target, a tool touching
it, the presses, the analytic spherical-cap oracle, and the files `dentdemo indent` writes."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dentdemo import interrupt, outputs
from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody, Carver
from dentdemo.carve.surface import create_maps
from dentdemo.errors import DentdemoError
from dentdemo.gl.context import GLContext
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.mesh.shapes import Tessellation, shape_mesh
from dentdemo.model.shapes import (
    Box,
    Capsule,
    Cylinder,
    Plate,
    Shape,
    Sphere,
    as_dict,
    support,
)

DOWN = np.array([0.0, -1.0, 0.0])


@dataclass
class PressSetup:
    """A target at the origin and a tool touching it at `contact.point`, ready to press."""

    target: CarveBody
    tool: CarveBody
    target_shape: Shape
    tool_shape: Shape
    contact: ContactFrame
    surface_normal: np.ndarray


#: How many sizes each kind takes on the command line (a box also takes one edge for a cube, a
#: capsule or cylinder its radius alone for a length of two radii).
_SIZES = {"plate": (1,), "box": (1, 3), "sphere": (1,), "capsule": (1, 2), "cylinder": (1, 2)}


def shape_from_args(kind: str, size: list[float], role: str) -> Shape:
    """Sizes: plate side; box edge (or x y z); sphere radius; capsule/cylinder radius [length]."""
    s = [float(x) for x in size]
    if kind not in _SIZES:
        raise DentdemoError(f"--{role}: unknown shape '{kind}' (known: {', '.join(_SIZES)})")
    if len(s) not in _SIZES[kind]:
        counts = " or ".join(str(n) for n in _SIZES[kind])
        raise DentdemoError(f"--{role}-size: a {kind} takes {counts} value(s), got {len(s)}")
    if not all(np.isfinite(x) and x > 0 for x in s):
        raise DentdemoError(f"--{role}-size: sizes must be positive finite metres, got {s}")
    match kind, s:
        case "plate", [side]:
            return Plate(side)
        case "sphere", [radius]:
            return Sphere(radius)
        case "box", [edge]:
            return Box((edge, edge, edge))
        case "box", [x, y, z]:
            return Box((x, y, z))
        case (("capsule" | "cylinder"), [radius, *rest]):
            solid = Capsule if kind == "capsule" else Cylinder
            return solid(radius, rest[0] if rest else 2 * radius)
    raise AssertionError((kind, s))


def aim_point(shape: Shape, offset: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The point above (x, z) = offset on the target's upper side, and its normal there."""
    x, z = offset
    match shape:
        case Sphere(radius=r):
            y2 = r * r - x * x - z * z
            point = np.array([x, np.sqrt(y2) if y2 > 0 else 0.0, z])
            return point, point / max(np.linalg.norm(point), 1e-30)
        case Plate():
            top = 0.0
        case _:
            top = float(support(shape, np.array([0.0, 1.0, 0.0]))[1])
    return np.array([x, top, z]), np.array([0.0, 1.0, 0.0])


def make_setup(
    gl: GLContext,
    target_shape: Shape,
    tool_shape: Shape,
    map_size: int,
    tool_map_size: int,
    offset: tuple[float, float] = (0.0, 0.0),
    direction: np.ndarray = DOWN,
    max_dent_depth: float = 0.1,
    tool_height: np.ndarray | None = None,
    detail: int = 2,
) -> PressSetup:
    """Build both bodies; the tool touches the target at the aim point with the surface normal."""
    target_mesh = shape_mesh(target_shape, Tessellation.press(detail))
    tool_mesh = shape_mesh(tool_shape, Tessellation.press(detail))
    target_gpu = GpuMesh(gl, target_mesh)
    target = CarveBody(target_gpu, create_maps(gl, target_gpu, map_size, max_dent_depth))
    point, normal = aim_point(target_shape, offset)
    tool_model = np.eye(4)
    tool_model[:3, 3] = point - support(tool_shape, -normal)
    tool_gpu = GpuMesh(gl, tool_mesh)
    tool = CarveBody(
        tool_gpu, create_maps(gl, tool_gpu, tool_map_size, max_dent_depth, tool_height), tool_model
    )
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    return PressSetup(target, tool, target_shape, tool_shape, ContactFrame(point, d), normal)


def cap_error(
    height: np.ndarray, side: float, centre_xz: tuple[float, float], radius: float, depth: float
) -> dict:
    """The spherical-cap oracle on a plate: RMS error relative to depth, footprint and volume."""
    rows, cols = height.shape
    u = (np.arange(cols) + 0.5) / cols
    v = (np.arange(rows) + 0.5) / rows
    x = (u[None, :] - 0.5) * side
    z = (0.5 - v[:, None]) * side
    r2 = (x - centre_xz[0]) ** 2 + (z - centre_xz[1]) ** 2
    expected = np.minimum(0.0, -depth + radius - np.sqrt(np.maximum(radius**2 - r2, 0.0)))
    expected = np.where(r2 < radius**2, expected, 0.0)
    footprint = np.sqrt(max(2 * radius * depth - depth**2, 0.0))
    texel = side / cols
    region = r2 <= (footprint + 2 * texel) ** 2
    rms = float(np.sqrt(np.mean((height[region] - expected[region]) ** 2))) if region.any() else 0.0
    cell = texel * (side / rows)
    volume_expected = float(-expected.sum() * cell)
    volume = float(-height.sum() * cell)
    return {
        "rms_error_m": rms,
        "rms_error_rel": rms / depth if depth > 0 else 0.0,
        "footprint_radius_expected_m": footprint,
        "volume_m3": volume,
        "volume_expected_m3": volume_expected,
    }


def footprint_radius(height: np.ndarray, texel_area: float, threshold: float = 1e-7) -> float:
    """Radius of a disc with the area of the dented texels, m."""
    return float(np.sqrt((height < -threshold).sum() * texel_area / np.pi))


def run_presses(
    gl: GLContext, setup: PressSetup, depth: float, tool_depth: float, repeat: int
) -> list[float]:
    """Press `repeat` times; milliseconds per press (each ended by glFinish). A press that cannot
    dent the target (the tool misses it or moves away from it) is an error, not an empty dent."""
    carver = Carver(gl)
    times = []
    try:
        for _ in range(repeat):
            interrupt.check()
            gl.ctx.finish()
            start = time.perf_counter()
            jobs = carver.carve(setup.target, setup.tool, setup.contact, depth, tool_depth)
            gl.ctx.finish()
            times.append((time.perf_counter() - start) * 1e3)
            if depth > 0 and not any(job.target is setup.target for job in jobs):
                raise DentdemoError(
                    "--offset/--normal: the tool cannot reach the target: it never meets it "
                    "moving along "
                    f"{np.round(setup.contact.direction, 4).tolist()} at "
                    f"{np.round(setup.contact.point, 4).tolist()} m; nothing was pressed"
                )
    finally:
        carver.release()
    return times


def write_outputs(
    gl: GLContext, setup: PressSetup, out: Path, depth: float, tool_depth: float, times: list[float]
) -> dict:
    """The maps, a 16-bit height PNG and summary.json into `out`, each file written atomically."""
    target_h = gl.read(setup.target.maps.height)[:, :, 0]
    tool_h = gl.read(setup.tool.maps.height)[:, :, 0]
    if depth > 0 and not (target_h < 0).any():
        raise DentdemoError(
            "--offset/--normal: the tool never meets the target moving along "
            f"{np.round(setup.contact.direction, 4).tolist()}; nothing was pressed"
        )
    outputs.write_npy(out / "target_height.npy", target_h)
    outputs.write_npy(out / "tool_height.npy", tool_h)
    outputs.write_normal_png(out / "target_normal.png", gl.read(setup.target.maps.normal))
    outputs.write_normal_png(out / "tool_normal.png", gl.read(setup.tool.maps.normal))
    outputs.write_height_png(out / "target_height.png", target_h, setup.target.maps.max_dent_depth)
    tu, tv = setup.target.maps.texel_metres
    summary = {
        "target": as_dict(setup.target_shape),
        "tool": as_dict(setup.tool_shape),
        "depth_m": depth,
        "tool_depth_m": tool_depth,
        "map_size": list(setup.target.maps.size),
        "repeat": len(times),
        "max_depth_m": float(-target_h.min()),
        "tool_max_depth_m": float(-tool_h.min()),
        "dented_texels": int((target_h < -1e-7).sum()),
        "footprint_radius_m": footprint_radius(target_h, tu * tv),
        "ms_per_press": float(np.median(times)),
        "ms_per_press_all": [round(t, 3) for t in times],
        "renderer": gl.renderer,
    }
    straight = np.allclose(setup.contact.direction, DOWN)
    match setup.target_shape, setup.tool_shape:
        case Plate(side=side), Sphere(radius=radius) if straight and depth > 0:
            offset = (float(setup.contact.point[0]), float(setup.contact.point[2]))
            summary["cap"] = cap_error(target_h, side, offset, radius, depth)
    outputs.write_json(out / "summary.json", summary)
    return summary
