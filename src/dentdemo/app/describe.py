"""What a frame of the sandbox shows, described for the renderer (render/frame.py): every body at
its pose with its maps and look, the light, the ground, and the debug overlays asked for."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dentdemo.app.scenery import Scenery
from dentdemo.app.simulation import Simulation
from dentdemo.model.shapes import Plane
from dentdemo.render.camera import OrbitCamera
from dentdemo.render.frame import DrawItem, FrameDescription, Inset, RenderOptions


def describe(
    sim: Simulation, scenery: Scenery, camera: OrbitCamera, options: RenderOptions
) -> FrameDescription:
    """The frame as the renderer needs it: every body at its pose with its maps and its drawn
    parts (`scenery`, brought up to date), the light, the ground, and the debug overlays the
    options ask for."""
    parts = scenery.sync(sim)
    items: list[DrawItem] = []
    ground_y: float | None = None
    for body_id, body in sim.bodies.items():
        if isinstance(body.spec.shape, Plane):
            ground_y = body.spec.position[1]
            continue
        model = sim.model(body_id)
        look = body.spec.material.appearance
        drawn = parts[body_id]
        items.append(DrawItem(body.gpu_mesh, model, look, body.maps, drawn.texture, drawn.coarser))
        if drawn.under is not None:
            items.append(DrawItem(drawn.under, model, look))
    lines = np.zeros((0, 6), np.float32)
    if options.contacts:
        lines = _contact_lines(sim)
    inset = None
    address = sim.address_map() if options.address_map else None
    if address is not None:
        inset = Inset(*address)
    return FrameDescription(items, camera, sim.scene.light, options, ground_y, lines, inset)


def _contact_lines(sim: Simulation) -> NDArray[np.float32]:
    """Impacts (yellow to red, along the normal, 10 cm) and carves (green ticks, 4 cm up)."""
    rows = []
    for impact in sim.last_impacts[-512:]:
        p, n = impact.point, impact.normal
        rows += [[*p, 1.0, 0.9, 0.1], [*(p + 0.1 * n), 1.0, 0.2, 0.1]]
    for p in list(sim.carved_points)[-256:]:
        rows += [[*(p + [0, 0.002, 0]), 0.1, 1.0, 0.3], [*(p + [0, 0.04, 0]), 0.1, 1.0, 0.3]]
    return np.asarray(rows, np.float32).reshape(-1, 6)
