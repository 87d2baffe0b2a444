"""Compact saved states: instead of every height map on every save, a state folder holds a
checkpoint (none while the run has carved only from its scene as loaded) and the hit log since
it (app/hitlog.py); a load rebuilds the maps by carving the log onto the checkpoint.

The folder of a compact save:

- `state.json`: as a full save's (physics, queue, collision shapes, statistics), with no maps
  listed, plus `hit_log` (the log file and its sha256) and `checkpoint` (null, or
  `checkpoint.json` and its sha256);
- `hits.ddhl`: the hit log since the checkpoint (the binary form);
- `checkpoint.json` with the `<body>.npy` maps it lists: a full state, as the run was when the
  log began, and each body's normal map as the carve left it (`<body>.normal.npy`, RGBA8: a
  full state's normals are rebuilt from its heights over the whole map, which differs from the
  carve's passes over each footprint by a few 255ths); written again by each save from what
  the run keeps in memory (the maps are read back from the GPU only when a checkpoint is made:
  at a save whose log holds `every_hits` hits or more, and at a load of a full state).

What a save costs grows with the hits since the checkpoint (183 bytes a hit on ball_drop), and
what a load costs with carving them; `every_hits` bounds both."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from dentdemo.app.hitlog import HitRecorder
from dentdemo.model import hitlog
from dentdemo.model.hitlog import Record

if TYPE_CHECKING:
    from dentdemo.app.simulation import Simulation

LOG_FILE = "hits.ddhl"
CHECKPOINT_FILE = "checkpoint.json"
#: The default: a save whose log holds this many hits makes a new checkpoint (a load then
#: carves at most this many; about a second on llvmpipe).
EVERY_HITS = 1000


@dataclass
class Checkpoint:
    """A full state as the run was when the log began: state.json's payload, the `.npy` files'
    bytes by name, and the heights and normal maps (RGBA8 [v, u, 4]) they hold by body."""

    payload: dict[str, Any]
    files: dict[str, bytes]
    heights: dict[str, NDArray[np.float32]]
    normals: dict[str, NDArray[np.uint8]]


@dataclass
class CompactSaves:
    """A Simulation's compact saves: the recorder of its log since the checkpoint, and the
    checkpoint (None: the scene as loaded)."""

    every_hits: int = EVERY_HITS
    recorder: HitRecorder = field(default_factory=HitRecorder)
    checkpoint: Checkpoint | None = None

    def due(self) -> bool:
        """A save now makes a new checkpoint (the log is long enough)."""
        return self.recorder.hits >= max(self.every_hits, 1)

    def checkpoint_now(self, sim: Simulation, checkpoint: Checkpoint) -> None:
        """`checkpoint` is `sim` as it is now: the log starts again from it."""
        self.checkpoint = checkpoint
        self.recorder.restart(sim)

    def contents(self) -> tuple[dict[str, Any], dict[str, bytes]]:
        """state.json's keys and the files of a compact save, besides a full save's others."""
        log = hitlog.to_bytes(self.recorder.records)
        keys: dict[str, Any] = {
            "hit_log": {"file": LOG_FILE, "sha256": sha256(log), "hits": self.recorder.hits},
            "checkpoint": None,
        }
        files = {LOG_FILE: log}
        if self.checkpoint is not None:
            text = (json.dumps(self.checkpoint.payload, indent=2) + "\n").encode()
            keys["checkpoint"] = {
                "file": CHECKPOINT_FILE,
                "sha256": sha256(text),
                "normals": {
                    body_id: {
                        "file": normal_file(body_id),
                        "sha256": sha256(self.checkpoint.files[normal_file(body_id)]),
                    }
                    for body_id in sorted(self.checkpoint.normals)
                },
            }
            files.update(self.checkpoint.files)
            files[CHECKPOINT_FILE] = text
        return keys, files

    def resume(self, sim: Simulation, records: list[Record], checkpoint: Checkpoint | None) -> None:
        """Go on from a loaded compact state: its checkpoint, and its log as replayed."""
        self.checkpoint = checkpoint
        self.recorder.resume(records)


def normal_file(body_id: str) -> str:
    return f"{body_id}.normal.npy"


def sha256(data: bytes) -> str:
    """The hex SHA-256 a saved state records of each of its files."""
    return hashlib.sha256(data).hexdigest()
