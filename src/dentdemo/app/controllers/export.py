"""glTF export in the demo: key G and the panel's button write every body as it is now."""

from __future__ import annotations

from pathlib import Path

from dentdemo.app.controllers import Keys
from dentdemo.app.export import export_gltf
from dentdemo.app.simulation import Simulation
from dentdemo.app.status import Status

#: Where the demo's glTF key and button write by default (`demo --gltf` changes it).
GLTF_FILE = Path("dentdemo.glb")


class ExportController:
    """Where G writes, and the export's outcome on the status line."""

    def __init__(self, sim: Simulation, status: Status) -> None:
        self.sim = sim
        self.status = status
        self.path = GLTF_FILE

    def keys(self) -> Keys:
        return {"g": self.gltf}

    def gltf(self, path: Path | None = None) -> bool:
        """Write every body to glTF 2.0 (key G, panel "export glTF"), to `path` or `self.path`."""
        target = path or self.path
        return self.status.attempt(
            lambda: export_gltf(self.sim, target),
            lambda: f"exported {target} at t = {self.sim.world.time:.2f} s",
        )
