"""dentdemo: permanent dents from rigid-body collisions, carved into bump maps on the GPU.

Use it in your own moderngl program (examples/carve_in_your_context.py):

    mesh = dentdemo.mesh_from_triangles(positions, indices, uvs)  # re-atlased if UVs unfit
    target = dentdemo.DentableSurface(ctx, mesh, map_size=1024, max_dent_depth=0.01)
    ball = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Sphere(0.05)), 256,
                                    model=tool_pose)               # 4x4, at first touch
    dentdemo.Carver(ctx).press(target, ball, dentdemo.Contact(point, direction), depth=0.002)
    # bind target.normal (and .height) in your own shaders; the mesh is never changed

The API (each name has its own help, e.g. help(dentdemo.DentableSurface)):

    DentableSurface(ctx, mesh, map_size=1024, max_dent_depth=0.01, model=None)
        a Mesh or trimesh.Trimesh with maps of 16 to 4096 texels a side: .height (R32F m,
        < 0 in dents), .normal (RGBA8 tangent space), .model (4x4 world from local), .mesh
        (to draw), .heights() (read back, float32 [v, u]), .set_heights(array or .npy path),
        .set_bump_map(png, white_height) (both rebuild the normals), .release()
    Carver(ctx).press(target, tool, contact, depth, tool_depth=0.0) -> bool; .release()
    Contact(point, direction)       world metres; the way the tool moves
    mesh_from_triangles(positions, indices, uvs=None), load_mesh(path, scale=1.0) -> Mesh
        (own UVs kept when they are a unique atlas, else re-atlased with one warning)
    shape_mesh(Sphere(r), Box((x, y, z)), Capsule/Cylinder(r, length), Plate(side)) -> Mesh
    export_gltf(path, surfaces, names=None, looks=None) -> .glb/.gltf file: meshes, tangents,
        materials (looks: Appearance or preset names), normal maps, heights (16-bit PNG)
    Carver.log_to(sink, {name: surface}) every press, undo and repair as hit-log records;
    replay(records or log bytes, {name: surface}, carver) carves them onto other surfaces;
        dentdemo.hitlog: the records, to_bytes / to_lines / parse (binary or JSON Lines)

Mesh.tangents (n, 4): xyz = T along +u, w = handedness, B = cross(N, T) * w; a normal-map texel
m (rgb * 2 - 1) is T m.x + B m.y + N m.z. Mesh.source_vertex (n,): the caller's vertex each one
copies (seams, creases and a re-atlas split vertices). Calls keep the host's GL state and read
nothing back unless asked; a bad argument, or a released surface, raises a ValueError naming it;
a call where its surfaces' GL context is not current in the calling thread, a ContextError.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from dentdemo.version import VERSION

__version__ = VERSION  # pyproject.toml's, from the installed package's metadata


#: The public names (`from dentdemo import *`), each imported on first use.
__all__ = [
    "Appearance",
    "Box",
    "Capsule",
    "Carver",
    "Contact",
    "Cylinder",
    "DentableSurface",
    "Mesh",
    "Plate",
    "Sphere",
    "export_gltf",
    "load_mesh",
    "mesh_from_triangles",
    "replay",
    "shape_mesh",
]

#: Public name -> module that defines it; imported on first use, so that `import dentdemo` (and
#: the command line) stays light.
_EXPORTS = {
    "DentableSurface": "dentdemo.api",
    "Carver": "dentdemo.api",
    "Contact": "dentdemo.api",
    "export_gltf": "dentdemo.api",
    "replay": "dentdemo.api",
    "Appearance": "dentdemo.model.materials",
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
API = (
    "Carver",
    "Contact",
    "DentableSurface",
    "export_gltf",
    "load_mesh",
    "mesh_from_triangles",
    "replay",
    "shape_mesh",
)


if TYPE_CHECKING:  # what type checkers see behind the lazy imports below
    from dentdemo.api import Carver, Contact, DentableSurface, export_gltf, replay
    from dentdemo.mesh.loader import load_mesh, mesh_from_triangles
    from dentdemo.mesh.mesh import Mesh
    from dentdemo.mesh.shapes import shape_mesh
    from dentdemo.model.materials import Appearance
    from dentdemo.model.shapes import Box, Capsule, Cylinder, Plate, Sphere


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    if name == "hitlog":  # the records and their encodings (model/hitlog.py)
        return importlib.import_module("dentdemo.model.hitlog")
    raise AttributeError(f"module 'dentdemo' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*_EXPORTS, "__version__"])
