"""Meshes written by hand for the mesh tests and the bad-input table: a flat grid with a unique
atlas, and glTF files of it (JSON document, binary buffer, GLB bytes)."""

from __future__ import annotations

import json
import struct

import numpy as np


def grid(n: int = 4, side: float = 0.2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A flat square of n x n quads in the x-z plane, facing +Y, with u along +x and v along -z
    over [0.1, 0.9] (a unique atlas): positions, faces, uvs."""
    s = np.linspace(0.0, 1.0, n + 1)
    v, u = np.meshgrid(s, s, indexing="ij")
    uv = 0.1 + 0.8 * np.stack([u.ravel(), v.ravel()], 1)
    pos = np.stack([u.ravel() * side, np.zeros(u.size), -v.ravel() * side], 1)
    r, c = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    i0 = (r * (n + 1) + c).ravel()
    faces = np.concatenate(
        [np.stack([i0, i0 + 1, i0 + n + 2], 1), np.stack([i0, i0 + n + 2, i0 + n + 1], 1)]
    )
    return pos, faces, uv


def gltf(pos, faces, uv, material: bool) -> tuple[dict, bytes]:
    """A one-primitive glTF document and its binary buffer (positions, TEXCOORD_0, indices)."""
    pos, uv, idx = pos.astype("<f4"), uv.astype("<f4"), faces.astype("<u4").ravel()
    blob = pos.tobytes() + uv.tobytes() + idx.tobytes()
    views = [(0, pos.nbytes), (pos.nbytes, uv.nbytes), (pos.nbytes + uv.nbytes, idx.nbytes)]
    primitive: dict = {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2}
    doc: dict = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [primitive]}],
        "buffers": [{"byteLength": len(blob)}],
        "bufferViews": [{"buffer": 0, "byteOffset": o, "byteLength": n} for o, n in views],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": len(pos),
                "type": "VEC3",
                "min": pos.min(0).tolist(),
                "max": pos.max(0).tolist(),
            },
            {"bufferView": 1, "componentType": 5126, "count": len(uv), "type": "VEC2"},
            {"bufferView": 2, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
        ],
    }
    if material:
        doc["materials"] = [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.2, 0.1, 1]}}]
        primitive["material"] = 0
    return doc, blob


def glb(doc: dict, blob: bytes) -> bytes:
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text
    body += struct.pack("<II", len(blob), 0x004E4942) + blob
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body
