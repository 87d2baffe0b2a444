"""What the world is written out as: each dentable body's maps (`render --maps-dir`) and every
body as glTF 2.0 (`render --gltf`, the demo's G). Both read the maps back from the GPU."""

from __future__ import annotations

from pathlib import Path

from dentdemo import outputs
from dentdemo.app.simulation import Simulation
from dentdemo.mesh.shapes import plate_sides
from dentdemo.model.shapes import Plane, Plate


def export_maps(sim: Simulation, directory: Path) -> list[Path]:
    """Write each dentable body's height (.npy, float32 [v, u]) and normals (.png)."""
    written = []
    for body_id, body in sorted(sim.bodies.items()):
        if not body.spec.dentable:
            continue
        height = sim.gl.read(body.maps.height)[:, :, 0]
        outputs.write_npy(directory / f"{body_id}_height.npy", height)
        outputs.write_normal_png(directory / f"{body_id}_normal.png", sim.gl.read(body.maps.normal))
        written += [directory / f"{body_id}_height.npy", directory / f"{body_id}_normal.png"]
    return written


def export_gltf(sim: Simulation, path: Path) -> Path:
    """Every body at its current pose as glTF 2.0 (.glb or .gltf, dentdemo/gltf.py): meshes with
    tangents, the presets' materials, the meshes' own images, and the normal and height maps of
    the bodies that take dents, read back from the GPU. The ground plane (infinite) is left
    out."""
    from dentdemo.gltf import GltfBody, GltfPart, dented_part, write_gltf

    bodies = []
    for body_id, body in sim.bodies.items():
        if isinstance(body.spec.shape, Plane):
            continue
        look = body.spec.material.appearance
        parts = [
            dented_part(sim.gl, body.mesh, look, body.maps)
            if body.spec.dentable
            else GltfPart(body.mesh, look, name="surface")
        ]
        if isinstance(body.spec.shape, Plate):  # its sides: drawn, never dented
            parts.append(GltfPart(plate_sides(body.spec.shape), look, name="sides"))
        bodies.append(GltfBody(body_id, sim.model(body_id), tuple(parts)))
    return write_gltf(path, bodies)
