"""Selection and the mouse's tools: a click drops a ball, a right drag throws one, Ctrl + click
selects a body for the developer tools (its dents, a live view of its maps, the profiler strip),
whose window opens from key D or the panel's button; "add plate at target"."""

from __future__ import annotations

import moderngl
import numpy as np

from dentdemo.app import inputs
from dentdemo.app.controllers import Keys
from dentdemo.app.controllers.editor import PLATE_THICKNESS
from dentdemo.app.controllers.view import ViewController
from dentdemo.app.inputs import PanelState
from dentdemo.app.map_view import MapView
from dentdemo.app.profiler import Profiler
from dentdemo.app.simulation import Simulation
from dentdemo.model.scene import BodySpec
from dentdemo.model.shapes import Plate

DROP_HEIGHT = 1.0  # m above the clicked point
#: Where a thrown ball starts along the view ray: this many radii plus this many metres out.
THROW_START_RADII, THROW_START_M = 3.0, 0.05
#: A throw's speed is the panel's times the drag's strength, within these.
THROW_STRENGTH = (0.2, 3.0)


class ToolsController:
    """What the mouse does in the scene, and the developer tools' selection."""

    def __init__(self, sim: Simulation, view: ViewController, panel: PanelState) -> None:
        self.sim = sim
        self.view = view
        self.panel = panel
        #: The body the developer tools look at (Ctrl + click), or None.
        self.selected: str | None = None
        #: The last seconds of frame phases (the frame loop adds each frame).
        self.profiler = Profiler()
        #: Whether the developer tools' window is open.
        self.visible = False
        self._map_view: MapView | None = None
        self._plates = 0

    def keys(self) -> Keys:
        return {"d": self.toggle}

    def toggle(self) -> bool:
        """Open or close the developer tools' window (key D, the panel's button)."""
        self.visible = not self.visible
        return self.visible

    def ground_point(self, ndc_x: float, ndc_y: float) -> np.ndarray | None:
        """Where the view ray through a screen point meets the floor (y = 0), world metres."""
        origin, direction = self.view.ray(ndc_x, ndc_y)
        if direction[1] > -1e-6:
            return None
        return origin + direction * (-origin[1] / direction[1])

    def drop_ball(self, ndc_x: float, ndc_y: float) -> str | None:
        """Left click: a ball of the panel's material and radius, 1 m above the clicked point."""
        point = self.ground_point(ndc_x, ndc_y)
        if point is None:
            return None
        p = inputs.checked(self.panel)
        return self.sim.drop_ball(
            point + [0.0, DROP_HEIGHT, 0.0], (0, 0, 0), p.ball_material, p.ball_radius
        )

    def throw_ball(self, ndc_x: float, ndc_y: float, strength: float = 1.0) -> str:
        """Right drag: a ball from the camera along the view ray at the panel's speed."""
        origin, direction = self.view.ray(ndc_x, ndc_y)
        p = inputs.checked(self.panel)
        start = origin + direction * (p.ball_radius * THROW_START_RADII + THROW_START_M)
        speed = p.throw_speed * float(np.clip(strength, *THROW_STRENGTH))
        return self.sim.drop_ball(start, direction * speed, p.ball_material, p.ball_radius)

    def add_plate(self) -> str:
        """A static plate of the panel's material on the floor under the orbit target."""
        self._plates += 1
        body_id = f"plate_{self._plates}"
        while body_id in self.sim.bodies:
            self._plates += 1
            body_id = f"plate_{self._plates}"
        t = self.view.camera.target
        spec = BodySpec(
            id=body_id,
            shape=Plate(inputs.checked(self.panel).plate_side, thickness=PLATE_THICKNESS),
            material=self.sim.materials.get(self.panel.plate_material),
            position=(float(t[0]), 0.02, float(t[2])),
            static=True,
            texels_per_metre=1024,
        )
        self.sim.add_body(spec)
        return body_id

    def select_at(self, ndc_x: float, ndc_y: float) -> str | None:
        """Ctrl + click: select the body under a screen point (the first its view ray meets,
        by the collision shapes), or nothing; a selection opens the developer tools."""
        origin, direction = self.view.ray(ndc_x, ndc_y)
        self.selected = self.sim.world.ray_pick(origin, direction)
        self.visible = self.visible or self.selected is not None  # the tools show what it is
        return self.selected

    def selection_text(self) -> list[str]:
        """The selected body for the panel: name, material, dent count and deepest dent."""
        body = self.sim.bodies.get(self.selected) if self.selected else None
        if body is None:
            return ["nothing selected (Ctrl + click a body)"]
        dents = self.sim.dents.get(body.spec.id)
        count, deepest = (dents.count, dents.deepest) if dents else (0, 0.0)
        what = "takes dents" if body.spec.dentable else "takes no dents"
        return [
            f"{body.spec.id}: {type(body.spec.shape).__name__.lower()}, "
            f"{body.spec.material.name}, {what}",
            f"{count} dents, deepest {deepest * 1e3:.2f} mm "
            f"(bound {body.spec.material.max_dent_depth * 1e3:.0f} mm)",
        ]

    def map_textures(self) -> tuple[moderngl.Texture, moderngl.Texture] | None:
        """The selected body's maps for the panel, redrawn now on the GPU: its heights coloured
        as the height view colours them (RGBA8), and its normal map itself. None when nothing
        that takes dents is selected."""
        body = self.sim.bodies.get(self.selected) if self.selected else None
        if body is None or not body.spec.dentable:
            return None
        if self._map_view is None:
            self._map_view = MapView(self.sim.gl)
        legend_depth = self.view.options.legend_depth
        return self._map_view.update(body.maps, legend_depth), body.maps.normal

    def release(self) -> None:
        if self._map_view is not None:
            self._map_view.release()
