"""xatlas's atlas generation in a process of its own (run as a script by `loader.reatlas`).

xatlas-python crashes the process that calls it on some meshes (a segmentation fault on an
81 920-triangle sphere without texture coordinates; jpcy/xatlas#151), which no Python code can
catch. Run apart, such a crash ends this process only, and the loader names the mesh in one line.

Usage: python atlas_child.py IN.npz OUT.npz, where IN holds positions (n, 3) float32, indices
(m, 3) uint32, normals (n, 3) float32 and padding, resolution (the pack options); OUT receives
vmapping (k,), indices (m, 3) and uvs (k, 2): xatlas's own arrays. Imports numpy and xatlas only.
"""

from __future__ import annotations

import sys


def generate(source: str, target: str) -> None:
    import numpy as np
    import xatlas

    data = np.load(source)
    atlas = xatlas.Atlas()
    atlas.add_mesh(data["positions"], data["indices"], data["normals"])
    pack = xatlas.PackOptions()
    pack.padding = int(data["padding"])
    pack.resolution = int(data["resolution"])
    pack.bilinear = True
    atlas.generate(xatlas.ChartOptions(), pack)
    vmapping, indices, uvs = atlas[0] if hasattr(atlas, "__getitem__") else atlas.get_mesh(0)
    np.savez(target, vmapping=vmapping, indices=indices, uvs=uvs)


if __name__ == "__main__":
    generate(sys.argv[1], sys.argv[2])
