"""Every scene that ships loads, runs and leaves dents (made only from what is in the repository:
no downloads)."""

from __future__ import annotations

import numpy as np
import pytest

from dentdemo.app.controller import DemoController
from dentdemo.model.materials import load_materials
from dentdemo.resources import assets_dir

SCENES = sorted((assets_dir() / "scenes").glob("*.toml"))


def test_there_are_example_scenes_beyond_ball_drop():
    assert {p.stem for p in SCENES} >= {"ball_drop", "metal_row", "edges_and_rings"}


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
@pytest.mark.slow
def test_scene_runs_and_dents(gl, path):
    from dentdemo.model.scene import load_scene

    lib = load_materials()
    scene = load_scene(path, lib)
    app = DemoController(gl, scene, lib, (96, 54), quality="low")
    try:
        for _ in range(90):  # 1.5 s: every dropped body has landed
            app.sim.step()
        app.sim.apply_queued()
        dented = [
            body_id
            for body_id, body in app.sim.bodies.items()
            if body.spec.dentable and float(gl.read(body.maps.height).min()) < -1e-6
        ]
        assert len(dented) >= 2, dented
        image = app.view.renderer.read_rgb() if app.view.render() is not None else None
        assert image is not None and image.shape == (54, 96, 3) and np.ptp(image) > 20
    finally:
        app.close()


def test_metal_row_orders_the_dents_by_softness(gl):
    """The same ball from the same height: lead (softest, largest k) dents deepest, steel least."""
    from dentdemo.model.scene import load_scene

    lib = load_materials()
    app = DemoController(gl, load_scene(assets_dir() / "scenes/metal_row.toml", lib), lib, (96, 54))
    try:
        for _ in range(60):
            app.sim.step()
        app.sim.apply_queued()
        depth = {
            name: -float(gl.read(app.sim.bodies[f"plate_{name}"].maps.height).min())
            for name in ("steel", "aluminium", "lead")
        }
        k = {name: lib.get(name).k for name in depth}
        assert k["lead"] > k["aluminium"] > k["steel"]
        assert depth["lead"] > depth["aluminium"] > depth["steel"] > 0
    finally:
        app.close()
