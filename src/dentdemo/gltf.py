"""glTF 2.0 export of dented bodies: every body at its pose, with its tangent frame, its
metallic-roughness material, its own base-colour image, the rebuilt normal map and the height map.

What a file holds, per body (one node, translation/rotation/scale from the body's pose) and per
part (one primitive; a plate is its dented top and its undented sides):
- POSITION, NORMAL (local metres), TANGENT (xyz along +u, w = handedness: glTF's bitangent
  cross(NORMAL, TANGENT.xyz) * w is the one our normal maps are built with, `Mesh.tangents`),
  TEXCOORD_0 = the dent atlas `uvs`, TEXCOORD_1 = the mesh's own `texture_uvs` where its
  base-colour image is sampled by other coordinates;
- a material: baseColorFactor (linear RGB), metallicFactor and roughnessFactor from the preset,
  the mesh's own image as baseColorTexture, the normal map as normalTexture (tangent space,
  +Y along +v, as glTF has it), and in `extras.dentdemo_height` the height map as a 16-bit
  greyscale PNG: height_m = offset_m + metres_per_unit * value.

Images are written in image order (top row first) and texture coordinates as glTF counts them,
t = 1 - v (our v, like OBJ's, grows upwards from the image's bottom row). `.glb` is the binary
container; `.gltf` is the same JSON with the buffer and images embedded as data URIs.

The writer is plain JSON and one binary buffer (glTF's own layout): no writer in the stack
writes per-vertex tangents and two texture coordinate sets (trimesh's exporter has neither), and
a data-model library would leave the accessors, views and padding to us all the same.
"""

from __future__ import annotations

import base64
import json
import struct
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dentdemo.errors import DentdemoError
from dentdemo.gl.context import GLContext
from dentdemo.gl.state import preserved
from dentdemo.gpu.maps import SurfaceMaps
from dentdemo.mesh.mesh import Mesh
from dentdemo.model.materials import Appearance
from dentdemo.outputs import png_bytes, write_bytes
from dentdemo.version import VERSION

SUFFIXES = (".glb", ".gltf")
#: The material `extras` key that holds the height map.
HEIGHT_KEY = "dentdemo_height"
#: glTF's constants.
_FLOAT, _UINT = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_LINEAR, _LINEAR_MIPMAP_LINEAR = 9729, 9987
_CLAMP_TO_EDGE, _REPEAT = 33071, 10497
_GLB_MAGIC, _JSON_CHUNK, _BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942


@dataclass(frozen=True)
class GltfPart:
    """One primitive: a mesh (its body's local metres) with its look and, for a surface that
    takes dents, its maps as read back from the GPU."""

    mesh: Mesh
    look: Appearance
    #: RGBA8 tangent-space normals [v, u, 4], rows as the GPU holds them (row 0: v = 0).
    normal_map: NDArray[np.uint8] | None = None
    #: Heights [v, u], metres along the surface normal (< 0 in a dent), rows as the GPU.
    height_map: NDArray[np.float32] | None = None
    #: The lowest height the map can hold, metres (-max_dent_depth).
    height_floor: float = 0.0
    name: str = ""


@dataclass(frozen=True)
class GltfBody:
    """A node: its parts at one pose (4x4, world from local, metres)."""

    name: str
    model: NDArray[np.float64]
    parts: tuple[GltfPart, ...]


def dented_part(
    gl: GLContext, mesh: Mesh, look: Appearance, maps: SurfaceMaps, name: str = "surface"
) -> GltfPart:
    """A surface that takes dents, with its normal and height maps read back from the GPU (an
    export: never in the frame loop). The context's GL state is left as it was."""
    with preserved(gl.ctx):
        normal = gl.read(maps.normal)
        height = gl.read(maps.height)[:, :, 0]
    return GltfPart(mesh, look, normal, height, -maps.max_dent_depth, name)


def check_path(flag: str, path: Path) -> Path:
    """A file name glTF can be written to: .glb (binary) or .gltf (JSON, data embedded)."""
    if path.suffix.lower() not in SUFFIXES:
        raise DentdemoError(f"{flag}: '{path}' must end in .glb or .gltf")
    return path


def write_gltf(path: Path, bodies: Sequence[GltfBody]) -> Path:
    """Write `bodies` to `path` (.glb or .gltf, by its suffix), atomically."""
    check_path("glTF", path)
    binary = path.suffix.lower() == ".glb"
    document, buffer = build(bodies, binary)
    if binary:
        return write_bytes(path, glb_bytes(document, buffer))
    document["buffers"][0]["uri"] = _data_uri("application/octet-stream", buffer)
    return write_bytes(path, json.dumps(document, separators=(",", ":")).encode())


def glb_bytes(document: dict[str, Any], binary: bytes) -> bytes:
    """The binary container: a 12-byte header, the JSON chunk (padded with spaces) and the BIN
    chunk (padded with zeros), each 4-byte aligned."""
    text = json.dumps(document, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    length = 12 + 8 + len(text) + 8 + len(binary)
    return b"".join(
        [
            struct.pack("<III", _GLB_MAGIC, 2, length),
            struct.pack("<II", len(text), _JSON_CHUNK),
            text,
            struct.pack("<II", len(binary), _BIN_CHUNK),
            binary,
        ]
    )


def build(bodies: Sequence[GltfBody], binary: bool = True) -> tuple[dict[str, Any], bytes]:
    """The glTF JSON document and its one binary buffer; images are buffer views (`binary`,
    for .glb) or data URIs."""
    if not bodies:
        raise DentdemoError("glTF: there is no body to export")
    builder = _Builder(binary)
    nodes = [builder.body(body) for body in bodies]
    return builder.document(nodes), bytes(builder.buffer)


def trs(model: NDArray[np.float64]) -> dict[str, list[float]]:
    """A node's translation, rotation (unit quaternion x, y, z, w) and scale from a 4x4 model
    matrix (world from local) that is a rotation, a translation and per-axis scales; a mirror
    becomes a negative x scale. Shear cannot be written as TRS and is an error."""
    m = np.asarray(model, dtype=np.float64)
    if m.shape != (4, 4) or not np.isfinite(m).all():
        raise DentdemoError(f"glTF: a pose must be a finite 4x4 matrix, got {m.tolist()}")
    linear = m[:3, :3]
    scale = np.linalg.norm(linear, axis=0)
    if (scale < 1e-12).any():
        raise DentdemoError(f"glTF: a pose collapses an axis (scales {scale.tolist()})")
    rotation = linear / scale
    if np.linalg.det(rotation) < 0:
        scale[0], rotation[:, 0] = -scale[0], -rotation[:, 0]
    if np.abs(rotation.T @ rotation - np.eye(3)).max() > 1e-5:
        raise DentdemoError("glTF: a pose with shear cannot be a node's translation/rotation/scale")
    out = {"translation": m[:3, 3].tolist(), "rotation": quaternion(rotation).tolist()}
    if np.abs(scale - 1.0).max() > 1e-9:
        out["scale"] = scale.tolist()
    return out


def quaternion(rotation: NDArray[np.float64]) -> NDArray[np.float64]:
    """The unit quaternion (x, y, z, w), w >= 0, of a rotation matrix (column vectors), by the
    largest of its four squared components (numerically safe for every angle)."""
    r = np.asarray(rotation, dtype=np.float64)
    u, _, vt = np.linalg.svd(r)  # the nearest true rotation
    r = u @ vt
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    squares = np.array([1 + r[0, 0] - r[1, 1] - r[2, 2], 1 - r[0, 0] + r[1, 1] - r[2, 2]])
    squares = np.append(squares, [1 - r[0, 0] - r[1, 1] + r[2, 2], 1 + trace])  # 4x^2 ... 4w^2
    k = int(np.argmax(squares))
    s = 2.0 * np.sqrt(squares[k])  # 4 times the largest component
    x_y, x_z, y_z = r[1, 0] + r[0, 1], r[0, 2] + r[2, 0], r[2, 1] + r[1, 2]
    w_x, w_y, w_z = r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]
    q = [
        np.array([s * s / 4, x_y, x_z, w_x]),
        np.array([x_y, s * s / 4, y_z, w_y]),
        np.array([x_z, y_z, s * s / 4, w_z]),
        np.array([w_x, w_y, w_z, s * s / 4]),
    ][k] / s
    q /= np.linalg.norm(q)
    return -q if q[3] < 0 else q


def height_encoding(height: NDArray[np.float32], floor: float) -> tuple[float, float]:
    """(offset_m, metres_per_unit) of a 16-bit height image: value 0 is the floor (the deepest
    dent the map can hold), 65535 the highest point above 0 (0 itself without bumps)."""
    top = max(float(np.max(height)), 0.0)
    bottom = min(float(floor), float(np.min(height)), 0.0)
    span = top - bottom if top > bottom else 1e-3
    return bottom, span / 65535.0


class _Builder:
    """The arrays of a glTF document and its binary buffer, filled one body at a time."""

    def __init__(self, binary: bool) -> None:
        #: Images in the buffer (.glb), else data URIs (.gltf).
        self.binary = binary
        self.buffer = bytearray()
        self.views: list[dict[str, Any]] = []
        self.accessors: list[dict[str, Any]] = []
        self.images: list[dict[str, Any]] = []
        self.textures: list[dict[str, Any]] = []
        self.samplers: list[dict[str, Any]] = []
        self.materials: list[dict[str, Any]] = []
        self.meshes: list[dict[str, Any]] = []
        self.nodes: list[dict[str, Any]] = []

    def document(self, nodes: list[int]) -> dict[str, Any]:
        doc: dict[str, Any] = {
            "asset": {"version": "2.0", "generator": f"dentdemo {VERSION}"},
            "scene": 0,
            "scenes": [{"name": "dentdemo", "nodes": nodes}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "materials": self.materials,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{"byteLength": len(self.buffer)}],
        }
        for key, items in (
            ("images", self.images),
            ("textures", self.textures),
            ("samplers", self.samplers),
        ):
            if items:
                doc[key] = items
        return doc

    def view(self, data: bytes, target: int | None = None) -> int:
        self.buffer += b"\0" * (-len(self.buffer) % 4)  # every view starts 4-byte aligned
        view: dict[str, Any] = {"buffer": 0, "byteOffset": len(self.buffer)}
        view["byteLength"] = len(data)
        if target is not None:
            view["target"] = target
        self.buffer += data
        self.views.append(view)
        return len(self.views) - 1

    def accessor(self, array: NDArray[Any], kind: str, bounds: bool = False) -> int:
        """An accessor over float32 vectors (VEC2/3/4) or uint32 indices (SCALAR)."""
        if kind == "SCALAR":
            data = np.ascontiguousarray(array, dtype="<u4").ravel()
            target, component = _ELEMENT_ARRAY_BUFFER, _UINT
        else:
            data = np.ascontiguousarray(array, dtype="<f4")
            target, component = _ARRAY_BUFFER, _FLOAT
        accessor: dict[str, Any] = {
            "bufferView": self.view(data.tobytes(), target),
            "componentType": component,
            "count": len(data),
            "type": kind,
        }
        if bounds:
            accessor["min"] = data.min(axis=0).tolist()
            accessor["max"] = data.max(axis=0).tolist()
        self.accessors.append(accessor)
        return len(self.accessors) - 1

    def image(self, pixels: NDArray[Any], name: str) -> int:
        """A PNG image (rows top-down): a buffer view, or a data URI."""
        data = png_bytes(pixels)
        if self.binary:
            image = {"name": name, "bufferView": self.view(data), "mimeType": "image/png"}
        else:
            image = {"name": name, "uri": _data_uri("image/png", data)}
        self.images.append(image)
        return len(self.images) - 1

    def texture(self, pixels: NDArray[Any], atlas: bool, name: str) -> int:
        """An image and a texture that samples it, trilinear (mipmapped: a viewer makes the
        levels): clamped for an atlas (the dent maps), repeating for a mesh's own image, whose
        coordinates may tile. Without mipmaps a normal map's one-texel features alias at a
        distance (three.js and Blender disagreed by 8-14 degrees there); the README says how a
        normal map's levels should be made."""
        sampler = {
            "magFilter": _LINEAR,
            "minFilter": _LINEAR_MIPMAP_LINEAR,
            "wrapS": _CLAMP_TO_EDGE if atlas else _REPEAT,
        }
        sampler["wrapT"] = sampler["wrapS"]
        if sampler not in self.samplers:
            self.samplers.append(sampler)
        source = self.image(pixels, name)
        self.textures.append({"sampler": self.samplers.index(sampler), "source": source})
        return len(self.textures) - 1

    def body(self, body: GltfBody) -> int:
        primitives = [self.primitive(part, f"{body.name}/{part.name}") for part in body.parts]
        self.meshes.append({"name": body.name, "primitives": primitives})
        self.nodes.append({"name": body.name, "mesh": len(self.meshes) - 1, **trs(body.model)})
        return len(self.nodes) - 1

    def primitive(self, part: GltfPart, name: str) -> dict[str, Any]:
        mesh = part.mesh
        normals = _unit(mesh.normals)
        tangents = np.hstack([_unit(mesh.tangents[:, :3]), np.sign(mesh.tangents[:, 3:]) + 0.0])
        tangents[tangents[:, 3] == 0, 3] = 1.0
        attributes = {
            "POSITION": self.accessor(mesh.positions, "VEC3", bounds=True),
            "NORMAL": self.accessor(normals, "VEC3"),
            "TANGENT": self.accessor(tangents, "VEC4"),
            "TEXCOORD_0": self.accessor(_gltf_uv(mesh.uvs), "VEC2"),
        }
        base_coords = 0
        if mesh.base_colour_image is not None and mesh.texture_uvs is not None:
            attributes["TEXCOORD_1"] = self.accessor(_gltf_uv(mesh.texture_uvs), "VEC2")
            base_coords = 1
        material = self.material(part, name, base_coords)
        indices = self.accessor(mesh.indices, "SCALAR")
        return {"attributes": attributes, "indices": indices, "material": material, "mode": 4}

    def material(self, part: GltfPart, name: str, base_coords: int) -> int:
        look = part.look
        if look.coat_thickness > 0.0 and part.height_map is None:  # undented: the coat alone
            look = replace(
                look,
                base_colour=look.coat_colour,
                metalness=look.coat_metalness,
                roughness=look.coat_roughness,
            )
        pbr: dict[str, Any] = {
            "baseColorFactor": [*(float(c) for c in look.base_colour), 1.0],
            "metallicFactor": float(look.metalness),
            "roughnessFactor": float(look.roughness),
        }
        material: dict[str, Any] = {"name": name, "pbrMetallicRoughness": pbr}
        image = part.mesh.base_colour_image
        if image is not None:  # it replaces the base colour, as the renderer draws it
            pbr["baseColorFactor"] = [1.0, 1.0, 1.0, 1.0]
            texture = self.texture(image, False, f"{name} base colour")
            pbr["baseColorTexture"] = {"index": texture, "texCoord": base_coords}
        elif look.coat_thickness > 0.0 and part.height_map is not None:
            colour, metal_rough = coat_textures(look, part.height_map)
            pbr.update(baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=1.0)
            pbr["roughnessFactor"] = 1.0
            texture = self.texture(colour, True, f"{name} base colour")
            pbr["baseColorTexture"] = {"index": texture, "texCoord": 0}
            texture = self.texture(metal_rough, True, f"{name} metallic roughness")
            pbr["metallicRoughnessTexture"] = {"index": texture, "texCoord": 0}
        if part.normal_map is not None:
            normal = part.normal_map[::-1, :, :3]  # image order: top row v = 1
            texture = self.texture(normal, True, f"{name} normal")
            material["normalTexture"] = {"index": texture, "texCoord": 0}
        if part.height_map is not None:
            material["extras"] = {HEIGHT_KEY: self.height(part.height_map, part.height_floor, name)}
        self.materials.append(material)
        return len(self.materials) - 1

    def height(self, heights: NDArray[np.float32], floor: float, name: str) -> dict[str, Any]:
        """The height map as a 16-bit greyscale image (not sampled by any material slot: an
        image for displacement or for reading the dents back) and how to turn it into metres."""
        offset, per_unit = height_encoding(heights, floor)
        values = (heights.astype(np.float64) - offset) / per_unit
        values = np.clip(np.round(values), 0, 65535).astype(np.uint16)
        return {
            "image": self.image(values[::-1], f"{name} height"),
            "texCoord": 0,
            "metres_per_unit": per_unit,
            "offset_m": offset,
            "zero_level": -offset / per_unit,
            "height_m": "offset_m + metres_per_unit * value (16-bit greyscale, top row v = 1)",
        }


def coat_textures(
    look: Appearance, height: NDArray[np.float32]
) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """A coated surface's base-colour (sRGB) and metallic-roughness (G roughness, B metalness,
    linear) images, rows top-down (top row v = 1): per texel the coat's where it covers the
    texel (`Appearance.coated`: height >= -coat_thickness), the material's where a dent or a
    scratch goes deeper, as the renderer draws it."""
    coated = (height >= -look.coat_thickness)[::-1, :, None]
    linear = np.where(coated, look.coat_colour, look.base_colour)
    srgb = np.where(linear <= 0.0031308, linear * 12.92, 1.055 * np.power(linear, 1 / 2.4) - 0.055)
    rough = np.where(coated, look.coat_roughness, look.roughness)
    metal = np.where(coated, look.coat_metalness, look.metalness)
    metal_rough = np.concatenate([np.zeros_like(rough), rough, metal], axis=2)

    def byte(x: NDArray[np.float64]) -> NDArray[np.uint8]:
        return np.round(np.clip(x, 0.0, 1.0) * 255.0).astype(np.uint8)

    return byte(srgb), byte(metal_rough)


def _unit(vectors: NDArray[np.floating]) -> NDArray[np.float32]:
    """Vectors scaled to unit length in float32, as glTF checks NORMAL and TANGENT."""
    v = np.asarray(vectors, dtype=np.float64)
    v = v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-30)
    return v.astype(np.float32)


def _gltf_uv(uv: NDArray[np.floating]) -> NDArray[np.float32]:
    """Our (u, v) (v up from the image's bottom row) as glTF's (s, t) (t down from its top)."""
    out = np.array(uv, dtype=np.float32)
    out[:, 1] = 1.0 - out[:, 1]
    return out


def _data_uri(mime: str, data: bytes) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"
