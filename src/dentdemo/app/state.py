"""Saving and resuming damage: a folder with every body's height map (float32, exact), the physics
state as ODE holds it, the carves still queued, the scene it came from and a format version.
Resuming continues bit for bit as if the run had never stopped.

Layout of a state folder:
    state.json          format, version, scene (path, sha256), time, bodies, queue, counters
    <body id>.npy       height map of each dentable body, float32 [v, u], metres
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from dentdemo import outputs
from dentdemo.app.simulation import CarveRequest, Simulation, map_side
from dentdemo.carve.surface import rebuild_all_normals
from dentdemo.errors import DentdemoError
from dentdemo.mesh.shapes import shape_mesh
from dentdemo.model import shapes
from dentdemo.model.scene import BodySpec
from dentdemo.physics.world import Impact, WorldState

FORMAT = "dentdemo-state"
VERSION = 1
STATE_FILE = "state.json"


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _scene_hash(sim: Simulation) -> str:
    try:
        return _sha256(Path(sim.scene.source).read_bytes())
    except OSError as exc:
        raise DentdemoError(f"{sim.scene.source}: cannot read the scene ({exc.strerror})") from None


def _plain(value: Any) -> Any:
    """JSON-ready: arrays and tuples as lists (floats keep every bit through JSON)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


def _impact_dict(impact: Impact) -> dict[str, Any]:
    return {f.name: _plain(getattr(impact, f.name)) for f in dataclasses.fields(impact)}


def _impact(data: dict[str, Any]) -> Impact:
    fields = dict(data)
    for name in ("point", "normal", "vel_a", "vel_b"):
        fields[name] = np.asarray(fields[name], dtype=np.float64)
    for name in ("pose_a", "pose_b"):
        fields[name] = tuple(np.asarray(x, dtype=np.float64) for x in fields[name])
    return Impact(**fields)


def _added_body(spec: BodySpec) -> dict[str, Any]:
    """A body added while running (the demo's balls and plates): its spec, material by name."""
    fields = {f.name: _plain(getattr(spec, f.name)) for f in dataclasses.fields(spec)}
    fields["shape"] = shapes.as_dict(spec.shape)
    fields["material"] = spec.material.name
    return fields


def _spec(sim: Simulation, entry: dict[str, Any]) -> BodySpec:
    fields = dict(entry)
    fields["shape"] = shapes.from_dict(entry["shape"])
    fields["material"] = sim.materials.get(entry["material"])
    for key, value in fields.items():
        if isinstance(value, list):
            fields[key] = tuple(value)
    return BodySpec(**fields)


def save_state(sim: Simulation, directory: Path) -> Path:
    """Write the simulation's state into `directory` (the height maps first, state.json last;
    each file atomically)."""
    outputs.check_output_dir("--save-state", directory)
    scene_ids = {spec.id for spec in sim.scene.bodies}
    world = sim.world.snapshot()
    maps: dict[str, dict[str, Any]] = {}
    for body_id, body in sorted(sim.bodies.items()):
        if not body.spec.dentable:
            continue
        height = np.ascontiguousarray(sim.gl.read(body.maps.height)[:, :, 0], dtype=np.float32)
        data = outputs.npy_bytes(height)  # written as is, and hashed
        name = f"{body_id}.npy"
        outputs.write_bytes(directory / name, data)
        maps[body_id] = {"file": name, "shape": list(height.shape), "sha256": _sha256(data)}
    payload = {
        "format": FORMAT,
        "version": VERSION,
        "scene": {"file": str(sim.scene.source), "sha256": _scene_hash(sim)},
        "world": dataclasses.asdict(world),
        "added_bodies": [
            _added_body(body.spec)
            for body_id, body in sim.bodies.items()
            if body_id not in scene_ids
        ],
        "maps": maps,
        "queue": [
            {
                "impact": _impact_dict(r.impact),
                "depth_a": r.depth_a,
                "depth_b": r.depth_b,
                "model_a": _plain(r.model_a),
                "model_b": _plain(r.model_b),
            }
            for r in sim.queue
        ],
        "carved_points": [_plain(p) for p in sim.carved_points],
        "stats": dataclasses.asdict(sim.stats),
        "ball_count": sim.ball_count,
    }
    return outputs.write_json(directory / STATE_FILE, payload)


class _Bad(Exception):
    pass


def _map_side(sim: Simulation, spec: BodySpec) -> int:
    body = sim.bodies.get(spec.id)
    if body is not None and body.spec == spec:
        return int(body.maps.size[0])
    return map_side(spec, shape_mesh(spec.shape))


def _read_state(sim: Simulation, directory: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """state.json and the height maps, every check done before anything is changed."""
    path = directory / STATE_FILE
    if not directory.is_dir():
        raise DentdemoError(f"--load-state: '{directory}' is not a folder")
    try:
        payload = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DentdemoError(f"{path}: missing; '{directory}' is not a saved state") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DentdemoError(f"{path}: not a readable state file ({exc})") from None
    try:
        if not isinstance(payload, dict) or payload.get("format") != FORMAT:
            raise _Bad(f"format is {payload.get('format')!r}, expected {FORMAT!r}")
        if payload.get("version") != VERSION:
            raise _Bad(f"version is {payload.get('version')!r}; this dentdemo reads {VERSION}")
        scene = payload["scene"]
        if scene["sha256"] != _scene_hash(sim):
            raise _Bad(
                f"saved from scene {scene['file']}, which differs from {sim.scene.source} "
                "(sha256 of the file)"
            )
        heights: dict[str, np.ndarray] = {}
        added = {entry["id"] for entry in payload["added_bodies"]}
        # Map side of every body the state can hold: the scene's and the added ones.
        expected = {spec.id: _map_side(sim, spec) for spec in sim.scene.bodies}
        for entry in payload["added_bodies"]:
            if not outputs.is_safe_name(str(entry["id"])) or entry["id"] in expected:
                raise _Bad(f"added body id {entry['id']!r} is not a safe, new name")
            try:
                expected[entry["id"]] = _map_side(sim, _spec(sim, entry))
            except DentdemoError as exc:
                raise _Bad(f"added body '{entry['id']}': {exc}") from None
        for body_id, info in payload["maps"].items():
            file = directory / info["file"]
            if Path(info["file"]).name != info["file"] or not outputs.is_safe_name(body_id):
                raise _Bad(f"map entry '{body_id}' names '{info['file']}'")
            try:
                data = file.read_bytes()
            except OSError as exc:
                raise _Bad(f"{file.name}: cannot read ({exc.strerror})") from None
            if _sha256(data) != info["sha256"]:
                raise _Bad(f"{file.name}: content differs from what was saved (truncated?)")
            height = np.load(io.BytesIO(data), allow_pickle=False)
            if height.dtype != np.float32 or list(height.shape) != info["shape"]:
                raise _Bad(f"{file.name}: {height.dtype} {height.shape}, expected {info['shape']}")
            if not np.isfinite(height).all():
                raise _Bad(f"{file.name}: holds NaN or infinity")
            size = expected.get(body_id)
            if size is None:
                raise _Bad(f"map for '{body_id}', a body neither in the scene nor added")
            if (height.shape[1], height.shape[0]) != (size, size):
                raise _Bad(f"{file.name}: {height.shape} does not fit body '{body_id}' ({size}²)")
            heights[body_id] = height
        world = payload["world"]
        for body_id in world["order"]:
            if body_id not in sim.bodies and body_id not in added:
                raise _Bad(f"body '{body_id}' is not in the scene")
        for key in ("time", "step_index", "seed", "bodies"):
            world[key]  # noqa: B018 - a missing key fails here
    except _Bad as exc:
        raise DentdemoError(f"{path}: {exc}") from None
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise DentdemoError(f"{path}: malformed state ({type(exc).__name__}: {exc})") from None
    return payload, heights


def load_state(sim: Simulation, directory: Path) -> None:
    """Resume from `directory`: bodies, maps (normals rebuilt on the GPU), physics, queue. The
    simulation is reset to its scene first, so loading in a running demo equals loading in a new
    process; a bad state raises before anything changes."""
    payload, heights = _read_state(sim, directory)
    sim.reset()
    world = payload["world"]
    keep = set(world["order"])
    for body_id in [b for b in sim.bodies if b not in keep]:
        sim.remove_body(body_id)  # removed during the saved run (non-finite)
    for entry in payload["added_bodies"]:
        if entry["id"] not in sim.bodies:
            sim.add_body(_spec(sim, entry))
    sim.world.restore(
        WorldState(
            time=float(world["time"]),
            step_index=int(world["step_index"]),
            seed=int(world["seed"]),
            order=list(world["order"]),
            bodies={k: tuple(v) for k, v in world["bodies"].items()},
        )
    )
    for body_id, height in heights.items():
        body = sim.bodies[body_id]
        body.maps.height.write(height.tobytes())
        rebuild_all_normals(sim.gl, body.gpu_mesh, body.maps)
    sim.queue = deque(
        CarveRequest(
            _impact(r["impact"]),
            float(r["depth_a"]),
            float(r["depth_b"]),
            np.asarray(r["model_a"], dtype=np.float64),
            np.asarray(r["model_b"], dtype=np.float64),
        )
        for r in payload["queue"]
    )
    sim.carved_points.clear()
    sim.carved_points.extend(np.asarray(p, dtype=np.float64) for p in payload["carved_points"])
    for key, value in payload["stats"].items():
        setattr(sim.stats, key, value)
    sim.ball_count = int(payload["ball_count"])
