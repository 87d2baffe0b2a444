"""`dentdemo simulate`: physics only, no GL; one line (or JSON object) per impact."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from dentdemo.cli.args import add_scene, command, int_in


def register(sub: argparse._SubParsersAction) -> None:
    p = command(
        sub,
        "simulate",
        "run a scene's physics only and print its impacts",
        "dentdemo simulate --scene assets/scenes/ball_drop.toml --steps 240 --json",
    )
    add_scene(p, required=True)
    p.add_argument(
        "--steps", type=int_in(0, 10**8), required=True, help="frame steps of the scene's dt"
    )
    p.add_argument("--json", action="store_true", help="one JSON object per impact and line")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from dentdemo.model.materials import load_materials
    from dentdemo.model.scene import load_scene
    from dentdemo.physics.simulate import build_world  # loads ODE

    materials = load_materials(args.materials)
    scene = load_scene(Path(args.scene), materials)
    world = build_world(scene)
    count = 0
    start = time.perf_counter()
    try:
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
    finally:
        world.close()
    return 0
