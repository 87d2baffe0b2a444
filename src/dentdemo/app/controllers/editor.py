"""The material editor: a draft of one preset (app/editor.py's `MaterialEditor`), applied live
while valid, the dents it predicts, and saving it into the user's materials file. Its window
opens from key E or the panel's button."""

from __future__ import annotations

from pathlib import Path

from dentdemo.app.controllers import Keys
from dentdemo.app.controllers.reload import ReloadController
from dentdemo.app.editor import MaterialEditor, PredictedDent, predict_dent, with_preset
from dentdemo.app.inputs import PanelState
from dentdemo.app.simulation import Simulation
from dentdemo.app.status import Status
from dentdemo.errors import DentdemoError
from dentdemo.model.materials import MaterialLibrary

#: Where the editor saves when the demo was given no --materials file.
MATERIALS_FILE = Path("dentdemo_materials.toml")
#: The plates the predicted dents are for (and the panel's "add plate"), m.
PLATE_THICKNESS = 0.02


class EditorController:
    """The editor's draft, its window and its saves."""

    def __init__(
        self, sim: Simulation, panel: PanelState, status: Status, reload: ReloadController
    ) -> None:
        self.sim = sim
        self.panel = panel
        self.status = status
        self.reload = reload
        #: The preset being edited (its draft), on the ball's preset to begin with.
        self.material = MaterialEditor(sim.materials, panel.ball_material)
        #: Whether its window is open.
        self.visible = False
        reload.on_materials = self.follow

    def keys(self) -> Keys:
        return {"e": self.toggle}

    def toggle(self) -> bool:
        """Open or close the editor's window (key E, the panel's button)."""
        self.visible = not self.visible
        return self.visible

    def follow(self, materials: MaterialLibrary) -> None:
        """The draft after a reload: the same preset if it is still there, else the ball's."""
        name = self.material.name if self.material.name in materials.materials else None
        self.material.select(materials, name or self.panel.ball_material)

    def edit(self, key: str, value: object) -> bool:
        """Set one key of the edited preset (None removes an optional key). A valid draft is
        used at once, by every body of that preset and by new ones; an invalid one leaves the
        last valid preset in use, the validator's line in `editor.error`."""
        preset = self.material.set(key, value)
        if preset is None:
            return False
        materials = with_preset(self.sim.materials, preset)
        self.material.library = materials
        self.sim.set_materials(materials)
        return True

    def predicted_dents(self) -> list[PredictedDent]:
        """The dent a ball of the panel's material and radius, thrown at the panel's speed
        straight onto a plate, leaves in each preset as the plate and in the ball."""
        p, materials = self.panel, self.sim.materials
        ball = materials.get(p.ball_material)
        return [
            predict_dent(
                ball, p.ball_radius, p.throw_speed, materials.materials[name], PLATE_THICKNESS
            )
            for name in materials.names()
        ]

    def save(self) -> bool:
        """Write the edited preset into the user's materials file (the last --materials file;
        without one, `MATERIALS_FILE`, watched from then on), keeping its comments and order;
        the shipped presets are never written. The outcome becomes the status line."""
        from dentdemo.app.materials_save import save_preset

        files = self.reload.material_files
        path = files[-1] if files else MATERIALS_FILE
        try:
            save_preset(
                path, self.material.name, self.material.draft, self.sim.materials.calibration
            )
        except DentdemoError as exc:
            self.status.error(exc)
            return False
        if path not in files:
            self.reload.watch((*files, path), self.reload.scene_file)
        self.status.say(f"saved [materials.{self.material.name}] to {path}")
        return True
