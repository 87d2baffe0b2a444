"""Python's heap between the sandbox's frames: the cyclic garbage collector's oldest generation
scans every object alive (the modules, the scene, its meshes and GL wrappers), and in the sandbox
that full pass is a frame's hitch, landing in whichever phase allocated last (the carve's
planning, in the bench's ball drop). `settle` freezes what is alive once a scene is loaded, so
the frames' collections scan only what the frames allocate."""

from __future__ import annotations

import gc


def settle() -> None:
    """Collect the garbage there is now, then freeze every object alive (`gc.freeze`): the
    collector never scans them again. Frozen objects are still freed when their last reference
    goes; cyclic garbage among them waits for the next `settle` (a new frame loop, a reset, a
    loaded state), which unfreezes them first."""
    gc.unfreeze()
    gc.collect()
    gc.freeze()
