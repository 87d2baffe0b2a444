"""`dentdemo simulate`: physics only, no GL; prints the impacts of a scene."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import TYPE_CHECKING

from dentdemo.errors import DentdemoError
from dentdemo.model.materials import load_materials
from dentdemo.model.scene import Scene, load_scene

if TYPE_CHECKING:  # ODE loads on first use, so commands without physics run without libode
    from dentdemo.physics.world import PhysicsWorld


def build_world(scene: Scene) -> PhysicsWorld:
    """A PhysicsWorld with every body of the scene; mesh shapes load their triangles."""
    from dentdemo.physics.world import PhysicsWorld

    world = PhysicsWorld(scene.physics)
    for body in scene.bodies:
        arrays = None
        if body.shape.kind == "mesh":
            from dentdemo.mesh.loader import load_mesh

            mesh = load_mesh(body.shape.mesh_path, body.shape.scale)
            arrays = (mesh.positions, mesh.indices)
        try:
            world.add_body(body, arrays)
        except ValueError as exc:
            raise DentdemoError(f"{scene.source}: [body.{body.id}]: {exc}") from None
    return world


def run_simulate(args: argparse.Namespace) -> int:
    if args.steps < 0:
        raise DentdemoError(f"--steps must be >= 0, got {args.steps}")
    materials = load_materials(args.materials)
    scene = load_scene(Path(args.scene), materials)
    world = build_world(scene)
    count = 0
    start = time.perf_counter()
    for _ in range(args.steps):
        for impact in world.step():
            count += 1
            if args.json:
                print(json.dumps(impact.as_dict(), sort_keys=True))
            else:
                print(
                    f"step {impact.step:5d} t={impact.time:7.4f}s {impact.body_b:>18} -> "
                    f"{impact.body_a:<18} v={impact.approach_speed:6.3f} m/s "
                    f"j={impact.j:8.4f} N*s j1={impact.j_elastic:8.4f} N*s"
                )
    elapsed = time.perf_counter() - start
    if not args.json:
        for body_id in world.removed:
            print(f"removed non-finite body '{body_id}'")
        rate = args.steps / elapsed if elapsed > 0 else float("inf")
        print(
            f"{count} impacts in {args.steps} steps ({len(scene.bodies)} bodies, "
            f"{rate:.0f} steps/s, substeps {scene.physics.substeps})"
        )
    world.close()
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simulate", help="run a scene's physics only and print its impacts")
    p.add_argument("--scene", required=True, metavar="FILE")
    p.add_argument("--steps", type=int, required=True, help="frame steps of the scene's dt")
    p.add_argument("--materials", action="append", default=[], metavar="FILE")
    p.add_argument("--json", action="store_true", help="one JSON object per impact and line")
    p.set_defaults(handler=run_simulate)
