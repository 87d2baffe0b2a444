"""Hot reload: the user's materials files and the scene file, polled while the demo runs (content
hashes, app/watch.py). A saved materials file applies at once; a saved scene is checked and
offered, and the next reset loads it."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

from dentdemo.app.controllers import Keys
from dentdemo.app.simulation import Simulation
from dentdemo.app.status import Status
from dentdemo.app.watch import FileWatcher
from dentdemo.errors import DentdemoError
from dentdemo.model.materials import MaterialLibrary, load_materials, reloaded_line
from dentdemo.model.scene import Scene, load_scene


class ReloadController:
    """The watched files and what a change to them does."""

    def __init__(self, sim: Simulation, status: Status) -> None:
        self.sim = sim
        self.status = status
        #: The user's materials files and the scene file, watched once `watch` was called.
        self.material_files: tuple[Path, ...] = ()
        self.scene_file: Path | None = None
        self._watcher: FileWatcher | None = None
        #: The scene file changed on disk (and is valid): the next reset loads it.
        self.scene_changed = False
        #: Called with the library after every reload (the editor follows it).
        self.on_materials: Callable[[MaterialLibrary], None] = lambda _: None

    def keys(self) -> Keys:
        return {}  # R (reset) is the coordinator's: it takes `new_scene` when there is one

    def watch(self, material_files: Sequence[Path], scene_file: Path | None) -> None:
        """Watch the user's materials files and the scene file: `poll` (each frame) applies a
        saved change to the materials and offers a reset to a changed scene."""
        self.material_files = tuple(Path(p) for p in material_files)
        self.scene_file = None if scene_file is None else Path(scene_file)
        watched = self.material_files + (() if self.scene_file is None else (self.scene_file,))
        self._watcher = FileWatcher(watched)

    def poll(self, now: float | None = None) -> list[str]:
        """Look at the watched files (at most every POLL_INTERVAL seconds of `now`, default the
        monotonic clock) and act on what changed; returns the lines reported (stderr and the
        status line): `dentdemo: reloaded F (N materials)`, or the one-line error that the same
        file would give at start-up, the last good values kept."""
        if self._watcher is None:
            return []
        changed = self._watcher.poll(time.monotonic() if now is None else now)
        lines: list[str] = []
        edited = [path for path in changed if path in self.material_files]
        if edited:
            lines += self._reload_materials(edited)
        if self.scene_file in changed:
            lines.append(self._scene_edited(self.scene_file))
        return lines

    def _reload_materials(self, edited: list[Path]) -> list[str]:
        """Load every materials file again after a save of `edited` ones: one line each, or the
        first error's line and nothing changed."""
        before = self.sim.materials
        try:
            materials = load_materials(self.material_files)
            self.sim.set_materials(materials, str(edited[0]))
        except DentdemoError as exc:
            return [self.status.error(exc)]
        self.on_materials(materials)
        if self.scene_changed and self.scene_file is not None:
            self._scene_edited(self.scene_file)  # the new scene with the new presets
        return [self.status.report(reloaded_line(before, materials, str(p))) for p in edited]

    def _scene_edited(self, path: Path) -> str:
        try:
            scene = load_scene(path, self.sim.materials)
        except DentdemoError as exc:
            self.scene_changed = False
            return self.status.error(exc)
        self.scene_changed = True
        return self.status.report(
            f"dentdemo: {path} changed ({len(scene.bodies)} bodies): reset (R) to load it"
        )

    def new_scene(self) -> Scene | None:
        """The changed scene file as it is now, for a reset; None when it did not change, or
        was edited again since into something invalid (its line reported)."""
        if not self.scene_changed or self.scene_file is None:
            return None
        try:
            scene = load_scene(self.scene_file, self.sim.materials)
        except DentdemoError as exc:
            self.status.error(exc)
            return None
        self.scene_changed = False
        return scene
