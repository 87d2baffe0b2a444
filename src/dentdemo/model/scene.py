"""Scene files (assets/scenes/*.toml): bodies, camera and light, validated as strictly as the
materials. Pure data: no OpenGL, no ODE.

Units: metres, kilograms, seconds; rotations are XYZ Euler angles in degrees (applied X, then Y,
then Z, about the world axes); velocities in m/s and rad/s.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dentdemo.errors import ConfigError
from dentdemo.model.materials import Material, MaterialLibrary
from dentdemo.model.shapes import (
    KINDS,
    Box,
    Capsule,
    Cylinder,
    MeshFile,
    Plane,
    Plate,
    Shape,
    Sphere,
)
from dentdemo.model.validate import TableReader, load_toml

SHAPE_KINDS = tuple(KINDS)
DEFAULT_TEXELS_PER_METRE = 256.0

#: A body id that is safe as a file name on every platform (it names the body's map files):
#: letters, digits, '_', '-', '.', starting with a letter or digit (no path separators, no '..',
#: no hidden files).
SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")


def is_safe_name(name: str) -> bool:
    return bool(SAFE_NAME.fullmatch(name)) and ".." not in name


@dataclass(frozen=True)
class Bounds:
    """Plausibility bounds of a scene: finite values beyond these are typing errors, not
    experiments (README, "Scene files")."""

    gravity: float = 1000.0  # m/s^2, length of the vector (about 100 g)
    speed: float = 1000.0  # m/s, length of a body's velocity
    spin: float = 1000.0  # rad/s, length of a body's angular velocity
    position: float = 1000.0  # m from the origin, bodies, camera eye and target
    size_min: float = 1e-3  # m: radius, length, side, thickness, box edges
    size_max: float = 100.0  # m
    mesh_scale_max: float = 1000.0
    substeps: int = 64
    solver_iterations: int = 1000
    impact_speed_min: float = 100.0  # m/s
    texels_per_metre_max: float = 16384.0
    bump_height_max: float = 0.1  # m


BOUNDS = Bounds()


@dataclass(frozen=True)
class BodySpec:
    """One body of a scene."""

    id: str
    shape: Shape
    material: Material
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    #: Orientation quaternion (w, x, y, z).
    orientation: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    static: bool = False
    #: Surface-map density, texels per metre.
    texels_per_metre: float = DEFAULT_TEXELS_PER_METRE
    #: False: the body takes no dents (its maps are never carved).
    dentable: bool = True
    #: Optional greyscale PNG laid over the body's atlas as its start height (white = bump_height).
    bump_map: str = ""
    #: Height of white in the bump map, m (bumps stand out of the surface).
    bump_height: float = 0.0


@dataclass(frozen=True)
class CameraSpec:
    eye: tuple[float, float, float] = (2.2, 1.6, 2.6)
    target: tuple[float, float, float] = (0.0, 0.15, 0.0)
    fov_deg: float = 45.0


@dataclass(frozen=True)
class LightSpec:
    #: Direction the light travels (world), normalised when used.
    direction: tuple[float, float, float] = (-0.4, -1.0, -0.3)
    colour: tuple[float, float, float] = (1.0, 0.97, 0.9)
    intensity: float = 1.5
    ambient: float = 0.3


@dataclass(frozen=True)
class PhysicsSpec:
    gravity: tuple[float, float, float] = (0.0, -9.81, 0.0)
    #: Frame step, s; each is split into `substeps` ODE steps.
    dt: float = 1.0 / 60.0
    substeps: int = 8
    #: Below this approach speed (m/s) a contact is resting, not an impact.
    impact_speed_min: float = 0.1
    solver_iterations: int = 40
    #: Scratches: sliding contacts wear Archard's volume (V = K F s / H) times this; 0, no wear
    #: is tracked. 1 is the law as the presets' K and H give it (microns: invisible at a
    #: sandbox's texels); a scene that shows scratches exaggerates it.
    wear_scale: float = 0.0


@dataclass(frozen=True)
class Scene:
    name: str
    source: str
    bodies: tuple[BodySpec, ...]
    camera: CameraSpec = field(default_factory=CameraSpec)
    light: LightSpec = field(default_factory=LightSpec)
    physics: PhysicsSpec = field(default_factory=PhysicsSpec)


def euler_deg_to_quat(angles: tuple[float, float, float]) -> tuple[float, float, float, float]:
    """XYZ Euler angles in degrees (X first, about world axes) to a unit quaternion (w, x, y, z)."""
    out = np.array([1.0, 0.0, 0.0, 0.0])
    for axis, angle in enumerate(angles):
        half = math.radians(angle) / 2
        q = np.zeros(4)
        q[0] = math.cos(half)
        q[1 + axis] = math.sin(half)
        out = quat_mul(q, out)
    w, x, y, z = (float(v) for v in out / np.linalg.norm(out))
    return (w, x, y, z)


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of quaternions (w, x, y, z)."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def load_scene(path: Path, materials: MaterialLibrary) -> Scene:
    """Read and validate a scene file."""
    source = str(path)
    data = load_toml(Path(path))
    for key in data:
        if key not in ("scene", "camera", "light", "physics", "body"):
            raise ConfigError(
                source, f"[{key}]", "unknown table (expected scene, camera, light, physics, body)"
            )
    scene_t = TableReader(source, "scene", data.get("scene", {}))
    name = scene_t.string("name", Path(path).stem)
    scene_t.finish()
    camera = _camera(source, data.get("camera", {}))
    light = _light(source, data.get("light", {}))
    physics = _physics(source, data.get("physics", {}))
    raw_bodies = data.get("body", [])
    if not isinstance(raw_bodies, list):
        raise ConfigError(source, "[body]", "bodies are an array of tables: write [[body]]")
    bodies = []
    seen: set[str] = set()
    for index, table in enumerate(raw_bodies):
        body = _body(source, index, table, materials)
        if body.id in seen:
            raise ConfigError(
                source, f"[[body]] #{index + 1} key 'id' = {body.id!r}", "duplicate id"
            )
        seen.add(body.id)
        bodies.append(body)
    return Scene(name, source, tuple(bodies), camera, light, physics)


def _camera(source: str, table: Any) -> CameraSpec:
    r = TableReader(source, "camera", table)
    d = CameraSpec()
    spec = CameraSpec(
        r.vec3("eye", d.eye, max_norm=BOUNDS.position, what="distance from the origin (m)"),
        r.vec3("target", d.target, max_norm=BOUNDS.position, what="distance from the origin (m)"),
        r.number("fov_deg", d.fov_deg, min_value=1.0, max_value=170.0),
    )
    r.finish()
    if np.allclose(spec.eye, spec.target):
        raise ConfigError(source, "[camera]", "eye and target must differ")
    return spec


def _light(source: str, table: Any) -> LightSpec:
    r = TableReader(source, "light", table)
    d = LightSpec()
    direction = r.vec3("direction", d.direction)
    if np.linalg.norm(direction) < 1e-9:
        raise r.fail("direction", "must not be zero")
    spec = LightSpec(
        direction,
        r.vec3("colour", d.colour),
        r.number("intensity", d.intensity, min_value=0.0),
        r.number("ambient", d.ambient, min_value=0.0, max_value=1.0),
    )
    r.finish()
    return spec


def _physics(source: str, table: Any) -> PhysicsSpec:
    r = TableReader(source, "physics", table)
    d = PhysicsSpec()
    spec = PhysicsSpec(
        gravity=r.vec3("gravity", d.gravity, max_norm=BOUNDS.gravity, what="magnitude (m/s^2)"),
        dt=r.number("dt", d.dt, min_value=1e-5, max_value=0.1),
        substeps=r.integer("substeps", d.substeps, min_value=1, max_value=BOUNDS.substeps),
        impact_speed_min=r.number(
            "impact_speed_min",
            d.impact_speed_min,
            min_value=0.0,
            max_value=BOUNDS.impact_speed_min,
        ),
        solver_iterations=r.integer(
            "solver_iterations",
            d.solver_iterations,
            min_value=1,
            max_value=BOUNDS.solver_iterations,
        ),
        wear_scale=r.number("wear_scale", d.wear_scale, min_value=0.0, max_value=1e9),
    )
    r.finish()
    return spec


def _body(source: str, index: int, table: Any, materials: MaterialLibrary) -> BodySpec:
    label = table.get("id", f"#{index + 1}") if isinstance(table, dict) else f"#{index + 1}"
    r = TableReader(source, f"body.{label}", table)
    body_id = r.string("id")
    if not is_safe_name(body_id):
        raise r.fail(
            "id",
            "must be 1-64 letters, digits, '_', '-' or '.', starting with a letter or digit "
            "(it names the body's map files)",
        )
    kind = r.string("shape", choices=SHAPE_KINDS)

    def length(key: str, default: float | None = None) -> float:
        """A size in metres within the plausibility bounds."""
        return r.number(key, default, min_value=BOUNDS.size_min, max_value=BOUNDS.size_max)

    shape: Shape
    if kind == "sphere":
        shape = Sphere(length("radius"))
    elif kind == "box":
        size = r.vec3("size", None)
        if not all(BOUNDS.size_min <= x <= BOUNDS.size_max for x in size):
            raise r.fail("size", f"edges must lie in [{BOUNDS.size_min:g}, {BOUNDS.size_max:g}] m")
        shape = Box((size[0], size[1], size[2]))
    elif kind in ("capsule", "cylinder"):
        solid = Capsule if kind == "capsule" else Cylinder
        shape = solid(length("radius"), length("length"))
    elif kind == "plate":
        shape = Plate(length("side"), length("thickness", 0.02))
    elif kind == "mesh":
        mesh = r.string("mesh")
        path = (Path(source).parent / mesh) if not Path(mesh).is_absolute() else Path(mesh)
        if not path.is_file():
            raise r.fail("mesh", f"no such file: {path}")
        scale = r.number(
            "scale", 1.0, min_value=0.0, min_inclusive=False, max_value=BOUNDS.mesh_scale_max
        )
        shape = MeshFile(str(path), scale)
    else:
        shape = Plane()
    material = materials.get(r.string("material"), source, f"[body.{label}] key 'material'")
    static = r.boolean("static", kind == "plane")
    if kind == "plane" and not static:
        raise r.fail("static", "a plane is always static")
    angles = r.vec3("rotation_deg", (0.0, 0.0, 0.0))
    spec = BodySpec(
        id=body_id,
        shape=shape,
        material=material,
        position=r.vec3(
            "position",
            (0.0, 0.0, 0.0),
            max_norm=BOUNDS.position,
            what="distance from the origin (m)",
        ),
        orientation=euler_deg_to_quat(angles),
        velocity=r.vec3("velocity", (0.0, 0.0, 0.0), max_norm=BOUNDS.speed, what="speed (m/s)"),
        angular_velocity=r.vec3(
            "angular_velocity", (0.0, 0.0, 0.0), max_norm=BOUNDS.spin, what="spin (rad/s)"
        ),
        static=static,
        texels_per_metre=r.number(
            "texels_per_metre",
            DEFAULT_TEXELS_PER_METRE,
            min_value=1.0,
            max_value=BOUNDS.texels_per_metre_max,
        ),
        dentable=r.boolean("dentable", kind != "plane"),
        bump_map=_bump_path(r, source),
        bump_height=r.number(
            "bump_height_m", 0.002, min_value=0.0, max_value=BOUNDS.bump_height_max
        ),
    )
    r.finish()
    return spec


def _bump_path(r: TableReader, source: str) -> str:
    name = r.string("bump_map", "")
    if not name:
        return ""
    path = Path(name) if Path(name).is_absolute() else Path(source).parent / name
    if not path.is_file():
        raise r.fail("bump_map", f"no such file: {path}")
    return str(path)
