"""`dentdemo indent`: a deterministic press with no physics (the Brinell test of the method)."""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody, Carver
from dentdemo.carve.shapes import Shape
from dentdemo.carve.surface import GpuMesh, create_maps, load_height_png
from dentdemo.errors import DentdemoError
from dentdemo.gl.context import GLContext, create_headless

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


def shape_from_args(kind: str, size: list[float], role: str) -> Shape:
    """Sizes: plate side; box edge (or x y z); sphere radius; capsule/cylinder radius [length]."""
    s = [float(x) for x in size]
    if kind == "box" and len(s) == 1:
        s = s * 3
    if kind in ("capsule", "cylinder") and len(s) == 1:
        s = [s[0], 2 * s[0]]
    try:
        return Shape(kind, tuple(s))
    except DentdemoError as exc:
        raise DentdemoError(f"--{role}-size: {exc}") from None


def _aim_point(shape: Shape, offset: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The point above (x, z) = offset on the target's upper side, and its normal there."""
    x, z = offset
    if shape.kind == "sphere":
        r = shape.dims[0]
        y2 = r * r - x * x - z * z
        point = np.array([x, np.sqrt(y2) if y2 > 0 else 0.0, z])
        return point, point / max(np.linalg.norm(point), 1e-30)
    top = 0.0 if shape.kind == "plate" else float(shape.support(np.array([0.0, 1.0, 0.0]))[1])
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
    target_mesh = target_shape.mesh(detail)
    tool_mesh = tool_shape.mesh(detail)
    target_gpu = GpuMesh(gl, target_mesh)
    target = CarveBody(target_gpu, create_maps(gl, target_gpu, map_size, max_dent_depth))
    point, normal = _aim_point(target_shape, offset)
    tool_model = np.eye(4)
    tool_model[:3, 3] = point - tool_shape.support(-normal)
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


def run_indent(args: argparse.Namespace) -> int:
    out = Path(args.out)
    if args.depth < 0 or not np.isfinite(args.depth):
        raise DentdemoError(f"--depth must be a finite number >= 0, got {args.depth}")
    if args.tool_depth < 0 or not np.isfinite(args.tool_depth):
        raise DentdemoError(f"--tool-depth must be a finite number >= 0, got {args.tool_depth}")
    if args.repeat < 1:
        raise DentdemoError("--repeat must be at least 1")
    if not 16 <= args.map_size <= 8192:
        raise DentdemoError(f"--map-size must lie in [16, 8192], got {args.map_size}")
    direction = np.asarray(args.normal, dtype=np.float64)
    if not np.all(np.isfinite(direction)) or np.linalg.norm(direction) < 1e-9:
        raise DentdemoError("--normal must be a finite non-zero vector")
    target_shape = shape_from_args(args.target, args.target_size, "target")
    tool_shape = shape_from_args(args.tool, args.tool_size, "tool")
    tool_map = args.tool_map_size or args.map_size
    pattern = (
        load_height_png(Path(args.tool_pattern), tool_map, args.pattern_height)
        if args.tool_pattern
        else None
    )
    gl = create_headless()
    try:
        setup = make_setup(
            gl,
            target_shape,
            tool_shape,
            args.map_size,
            tool_map,
            tuple(args.offset),
            direction,
            args.max_dent_depth,
            pattern,
        )
        carver = Carver(gl)
        times = []
        for _ in range(args.repeat):
            gl.ctx.finish()
            start = time.perf_counter()
            carver.carve(setup.target, setup.tool, setup.contact, args.depth, args.tool_depth)
            gl.ctx.finish()
            times.append((time.perf_counter() - start) * 1e3)
        summary = _write_outputs(gl, setup, out, args, times)
    finally:
        gl.release()
    print(json.dumps(summary, indent=2))
    return 0


def _write_outputs(gl: GLContext, setup: PressSetup, out: Path, args, times: list[float]) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    target_h = gl.read(setup.target.maps.height)[:, :, 0]
    tool_h = gl.read(setup.tool.maps.height)[:, :, 0]
    np.save(out / "target_height.npy", target_h)
    np.save(out / "tool_height.npy", tool_h)
    save_normal_png(gl.read(setup.target.maps.normal), out / "target_normal.png")
    save_normal_png(gl.read(setup.tool.maps.normal), out / "tool_normal.png")
    save_height_png(target_h, setup.target.maps.max_dent_depth, out / "target_height.png")
    tu, tv = setup.target.maps.texel_metres
    summary = {
        "target": {"shape": setup.target_shape.kind, "size_m": list(setup.target_shape.dims)},
        "tool": {"shape": setup.tool_shape.kind, "size_m": list(setup.tool_shape.dims)},
        "depth_m": args.depth,
        "tool_depth_m": args.tool_depth,
        "map_size": list(setup.target.maps.size),
        "repeat": args.repeat,
        "max_depth_m": float(-target_h.min()),
        "tool_max_depth_m": float(-tool_h.min()),
        "dented_texels": int((target_h < -1e-7).sum()),
        "footprint_radius_m": footprint_radius(target_h, tu * tv),
        "ms_per_press": float(np.median(times)),
        "ms_per_press_all": [round(t, 3) for t in times],
        "renderer": gl.renderer,
    }
    straight = np.allclose(setup.contact.direction, DOWN)
    if (
        setup.target_shape.kind == "plate"
        and setup.tool_shape.kind == "sphere"
        and straight
        and args.depth > 0
    ):
        summary["cap"] = cap_error(
            target_h,
            setup.target_shape.dims[0],
            tuple(args.offset),
            setup.tool_shape.dims[0],
            args.depth,
        )
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary


def save_normal_png(normal: np.ndarray, path: Path) -> None:
    """An RGBA8 normal map as an RGB PNG, top row = v = 1 (image convention)."""
    Image.fromarray(np.ascontiguousarray(normal[::-1, :, :3])).save(path)


def save_height_png(height: np.ndarray, max_depth: float, path: Path) -> None:
    """Heights as 16-bit greyscale: 65535 = pristine (0 m), 0 = -max_depth; top row is v = 1."""
    scaled = np.clip(1.0 + height / max_depth, 0.0, 1.0) * 65535.0
    Image.fromarray(np.ascontiguousarray(np.round(scaled[::-1]).astype(np.uint16))).save(path)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("indent", help="press a tool into a target on the GPU, no physics")
    p.add_argument("--tool", choices=("sphere", "box", "capsule"), default="sphere")
    p.add_argument(
        "--tool-size",
        type=float,
        nargs="+",
        default=[0.05],
        metavar="M",
        help="sphere radius; box edge (or x y z); capsule radius [length], metres",
    )
    p.add_argument("--target", choices=("plate", "box", "sphere"), default="plate")
    p.add_argument(
        "--target-size",
        type=float,
        nargs="+",
        default=[1.0],
        metavar="M",
        help="plate side; box edge (or x y z); sphere radius, metres",
    )
    p.add_argument("--depth", type=float, required=True, help="dent the target receives, m")
    p.add_argument(
        "--offset",
        type=float,
        nargs=2,
        default=[0.0, 0.0],
        metavar=("X", "Z"),
        help="where on the target, metres from its centre",
    )
    p.add_argument(
        "--normal",
        type=float,
        nargs=3,
        default=[0.0, -1.0, 0.0],
        metavar=("X", "Y", "Z"),
        help="press direction (the way the tool moves)",
    )
    p.add_argument("--repeat", type=int, default=1, help="press this many times")
    p.add_argument("--map-size", type=int, default=512, help="target map side, texels")
    p.add_argument(
        "--tool-map-size", type=int, default=0, help="tool map side (default: --map-size)"
    )
    p.add_argument("--tool-pattern", metavar="PNG", help="greyscale height pattern on the tool")
    p.add_argument("--pattern-height", type=float, default=0.002, help="white in the pattern, m")
    p.add_argument("--tool-depth", type=float, default=0.0, help="dent the tool receives, m")
    p.add_argument(
        "--max-dent-depth", type=float, default=0.1, help="deepest height a map holds, m"
    )
    p.add_argument("--out", required=True, metavar="DIR")
    p.set_defaults(handler=run_indent)
