"""dentdemo: permanent dents from rigid-body collisions, carved into bump maps on the GPU.

Use it in your own moderngl program (examples/carve_in_your_context.py):

    import dentdemo
    mesh = dentdemo.mesh_from_triangles(positions, indices)   # re-atlased if it has no UVs
    ball = dentdemo.shape_mesh(dentdemo.Sphere(0.05))
    target = dentdemo.DentableSurface(ctx, mesh, map_size=1024, max_dent_depth=0.01)
    tool = dentdemo.DentableSurface(ctx, ball, model=tool_pose)    # posed at first touch
    carver = dentdemo.Carver(ctx)
    carver.press(target, tool, dentdemo.Contact(point, direction), depth=0.002)
    # bind target.normal (and target.height) in your shaders; the mesh is never changed

The API (each name has its own help, e.g. help(dentdemo.Carver)):

    DentableSurface(ctx, mesh, map_size=1024, max_dent_depth=0.01, model=None)
        a mesh with its maps: .height (R32F metres, < 0 in dents), .normal (RGBA8 tangent
        space), .model (4x4 world from local), .heights() (read back), .release()
    Carver(ctx).press(target, tool, contact, depth, tool_depth=0.0) -> bool
        dents both surfaces where the tool moves into the target; .release()
    Contact(point, direction)       world metres; the way the tool moves
    mesh_from_triangles(positions, indices, uvs=None)  -> Mesh (re-atlased when needed)
    load_mesh(path, scale=1.0)      -> Mesh, from anything trimesh reads
    shape_mesh(shape)               -> Mesh of Sphere(r), Box((x, y, z)), Capsule(r, length),
                                       Cylinder(r, length) or Plate(side) (all in metres)

Every call leaves the host's GL state as it was, and nothing is read back from the GPU unless
you ask (heights()). The command line is `dentdemo --help`.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

#: Public name -> module that defines it; imported on first use, so that `import dentdemo` (and
#: the command line) stays light.
_EXPORTS = {
    "DentableSurface": "dentdemo.api",
    "Carver": "dentdemo.api",
    "Contact": "dentdemo.api",
    "Mesh": "dentdemo.mesh.mesh",
    "mesh_from_triangles": "dentdemo.mesh.loader",
    "load_mesh": "dentdemo.mesh.loader",
    "shape_mesh": "dentdemo.mesh.shapes",
    "Sphere": "dentdemo.model.shapes",
    "Box": "dentdemo.model.shapes",
    "Capsule": "dentdemo.model.shapes",
    "Cylinder": "dentdemo.model.shapes",
    "Plate": "dentdemo.model.shapes",
}
#: The host's names (help(dentdemo) shows their summary above; each has its own help).
API = ("Carver", "Contact", "DentableSurface", "load_mesh", "mesh_from_triangles", "shape_mesh")


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'dentdemo' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*_EXPORTS, "__version__"])
