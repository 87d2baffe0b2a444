"""Meshes from files (OBJ, glTF, PLY, STL... through trimesh), with a check that the texture
coordinates are a unique atlas and an automatic re-atlas (xatlas) where they are not."""

from __future__ import annotations

import functools
import io
import json
import math
import os
import signal
import struct
import subprocess
import sys
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dentdemo.errors import ArgumentError, DentdemoError, MissingFileError
from dentdemo.mesh.mesh import DEGENERATE, Mesh, check_indices, doubled_areas
from dentdemo.mesh.normals import smooth_normals

#: Resolution of the raster used to find overlapping UV triangles.
OVERLAP_GRID = 256
#: Padding between xatlas charts, in texels of its packing resolution.
ATLAS_PADDING = 4
ATLAS_RESOLUTION = 1024
#: The script that runs xatlas in a process of its own (`reatlas`).
ATLAS_CHILD = Path(__file__).with_name("atlas_child.py")


@dataclass(frozen=True)
class UVReport:
    """What is wrong with a mesh's texture coordinates, if anything."""

    missing: bool = False
    tiled: bool = False  # coordinates outside [0, 1]
    overlapping: bool = False
    #: Share of sampled atlas cells covered by more than one triangle.
    overlap_fraction: float = 0.0
    #: Triangles (by index) with an area in space and none in the atlas: no texel of the maps
    #: would be theirs, so Mesh drops them (`flat_triangles`).
    flat: tuple[int, ...] = ()

    @property
    def ok(self) -> bool:
        return not (self.missing or self.tiled or self.overlapping or self.flat)

    def describe(self) -> str:
        parts = [
            n
            for n, bad in (
                ("missing", self.missing),
                ("tiled", self.tiled),
                ("overlapping", self.overlapping),
            )
            if bad
        ]
        if self.flat:
            shown = ", ".join(map(str, self.flat[:5])) + (", ..." if len(self.flat) > 5 else "")
            plural = "s" * (len(self.flat) > 1)
            parts.append(f"flat for triangle{plural} {shown} (no area in the atlas)")
        return ", ".join(parts) or "unique"


def check_uvs(
    uvs: NDArray[np.floating] | None,
    indices: NDArray[np.integer],
    positions: NDArray[np.floating] | None = None,
) -> UVReport:
    """Classify texture coordinates: missing, tiled (outside [0, 1]) or overlapping charts, and
    (given the positions) of no area for a triangle that has one in space."""
    if uvs is None or len(uvs) == 0:
        return UVReport(missing=True)
    uv = np.asarray(uvs, dtype=np.float64)
    if not np.isfinite(uv).all():
        return UVReport(missing=True)
    eps = 1e-4
    tiled = bool((uv < -eps).any() or (uv > 1 + eps).any())
    tris = np.asarray(indices).reshape(-1, 3)
    fraction = _overlap_fraction(uv, tris)
    flat = () if positions is None else tuple(flat_triangles(positions, uvs, tris).tolist())
    return UVReport(tiled=tiled, overlapping=fraction > 1e-3, overlap_fraction=fraction, flat=flat)


def flat_triangles(
    positions: NDArray[np.floating], uvs: NDArray[np.floating], indices: NDArray[np.integer]
) -> NDArray[np.int64]:
    """Indices of the triangles with an area in space and none in the atlas, measured as Mesh
    measures them when it drops degenerate triangles."""
    space, atlas = doubled_areas(positions, uvs, indices)
    return np.flatnonzero((space > DEGENERATE) & ~(atlas > DEGENERATE))


def _overlap_fraction(uv: NDArray[np.float64], tris: NDArray[np.integer]) -> float:
    """Rasterise every UV triangle at cell centres of an OVERLAP_GRID^2 grid; count cells hit
    twice or more (shared edges count once: sample points lie strictly inside)."""
    n = OVERLAP_GRID
    counts = np.zeros((n, n), dtype=np.int32)
    # Tiled coordinates are folded back into [0, 1] so repeats show up as overlaps.
    folded = np.where((uv < 0.0) | (uv > 1.0), np.mod(uv, 1.0), uv)
    t = folded[tris] * n
    lo = np.clip(np.floor(t.min(axis=1)).astype(int), 0, n - 1)
    hi = np.clip(np.ceil(t.max(axis=1)).astype(int), 0, n)
    for k in range(len(tris)):
        (x0, y0), (x1, y1) = lo[k], hi[k]
        if x1 <= x0 or y1 <= y0:
            continue
        ys, xs = np.mgrid[y0:y1, x0:x1] + 0.5
        a, b, c = t[k]
        d = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        if abs(d) < 1e-12:
            continue
        w1 = ((xs - a[0]) * (c[1] - a[1]) - (ys - a[1]) * (c[0] - a[0])) / d
        w2 = ((b[0] - a[0]) * (ys - a[1]) - (b[1] - a[1]) * (xs - a[0])) / d
        inside = (w1 > 1e-6) & (w2 > 1e-6) & (w1 + w2 < 1 - 1e-6)
        counts[y0:y1, x0:x1] += inside
    covered = (counts > 0).sum()
    return float((counts > 1).sum() / covered) if covered else 0.0


class AtlasFailure(Exception):
    """xatlas failed or crashed on a mesh (the caller names the mesh)."""


def reatlas(
    positions: NDArray, indices: NDArray, normals: NDArray, return_mapping: bool = False
) -> tuple:
    """New unique UVs from xatlas, with gutters between charts; returns (positions, normals, uvs,
    indices) with vertices split along the new seams. xatlas runs in a process of its own
    (`atlas_child.py`): where it fails or crashes, AtlasFailure says how, and this process goes
    on."""
    with tempfile.TemporaryDirectory(prefix="dentdemo-atlas-") as folder:
        source, target = Path(folder) / "in.npz", Path(folder) / "out.npz"
        np.savez(
            source,
            positions=positions.astype(np.float32),
            indices=indices.astype(np.uint32),
            normals=normals.astype(np.float32),
            padding=ATLAS_PADDING,
            resolution=ATLAS_RESOLUTION,
        )
        try:
            run = subprocess.run(
                [sys.executable, str(ATLAS_CHILD), str(source), str(target)],
                capture_output=True,
                text=True,
                check=False,
            )
        except OSError as exc:  # no interpreter to start (an embedded Python)
            raise AtlasFailure(f"xatlas could not be started ({exc})") from None
        if run.returncode != 0:
            raise AtlasFailure(_failure(run.returncode, run.stderr))
        with np.load(target) as out:
            vmapping, new_indices, uvs = out["vmapping"], out["indices"], out["uvs"]
    if return_mapping:  # which input vertex each output vertex copies
        return positions[vmapping], normals[vmapping], uvs, new_indices, vmapping
    return positions[vmapping], normals[vmapping], uvs, new_indices


def _failure(returncode: int, stderr: str) -> str:
    """How the atlas process ended: the signal that killed it, or its last line of error."""
    if returncode < 0:
        try:
            name = signal.Signals(-returncode).name
        except ValueError:
            name = f"signal {-returncode}"
        return f"xatlas crashed ({name})"
    lines = [line for line in stderr.strip().splitlines() if line.strip()]
    return f"xatlas failed ({lines[-1].strip() if lines else f'exit status {returncode}'})"


def load_mesh(path: str | Path, scale: float = 1.0) -> Mesh:
    """Load a triangle mesh file; its own texture coordinates are kept when they are a unique
    atlas, else it is re-atlased (one warning). A file is read (and re-atlased, and warned about)
    once per content and scale: physics and drawing share the result. Every failure is an
    ArgumentError (a ValueError) naming the file; a missing one is also a FileNotFoundError."""
    if not isinstance(path, str | os.PathLike):
        raise ArgumentError(f"path must be a mesh file's name, got {type(path).__name__}")
    path = Path(path)
    if not (isinstance(scale, int | float) and math.isfinite(scale) and scale > 0):
        raise ArgumentError(f"{path}: scale must be a positive finite number, got {scale!r}")
    try:
        stat = path.stat()
    except FileNotFoundError as exc:
        raise MissingFileError(f"{path}: cannot load mesh ({exc.strerror})") from None
    except OSError as exc:
        raise ArgumentError(f"{path}: cannot load mesh ({exc.strerror})") from None
    try:
        return _load_mesh(path.resolve(), str(path), float(scale), stat.st_mtime_ns, stat.st_size)
    except ArgumentError:
        raise
    except DentdemoError as exc:  # the file's content: not a mesh, corrupt, no triangles
        raise ArgumentError(str(exc)) from None


@functools.lru_cache(maxsize=32)
def _load_mesh(resolved: Path, shown: str, scale: float, mtime_ns: int, size: int) -> Mesh:
    """load_mesh's work; the file's time and size in the key make an edited file load anew."""
    import trimesh

    path = Path(shown)
    try:
        gltf = gltf_source(resolved, shown)
        if gltf is None:
            loaded = trimesh.load(resolved, **_MESH_ONLY)
        else:
            loaded = trimesh.load(gltf.data, file_type=gltf.kind, resolver=gltf.files, **_MESH_ONLY)
    except DentdemoError:
        raise
    except ImportError:
        # trimesh reaches for an optional charset detector when a text format is not UTF-8:
        # the file is corrupt (or not a mesh), not the installation.
        raise DentdemoError(
            f"{path}: cannot load mesh (not UTF-8 text, nor a binary format trimesh reads)"
        ) from None
    except Exception as exc:  # trimesh raises many types for unreadable files
        detail = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise DentdemoError(f"{path}: cannot load mesh ({detail})") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise DentdemoError(f"{path}: no triangles found")
    if gltf is not None and gltf.draco and not np.any(loaded.vertices):
        # trimesh logs a failed decode and leaves the accessors' zero placeholders.
        raise DentdemoError(f"{path}: its {DRACO} data could not be decoded (corrupt?)")
    return mesh_from_trimesh(loaded, name=str(path), scale=scale)


_MESH_ONLY: dict[str, Any] = {"force": "mesh", "process": False}
#: glTF geometry compression: Draco's is decoded (trimesh with DracoPy), meshoptimizer's is not.
DRACO, MESHOPT = "KHR_draco_mesh_compression", "EXT_meshopt_compression"
#: The material given to glTF primitives that have texture coordinates but no material: without
#: one, trimesh drops the coordinates (its colour visuals hold none).
_PLAIN_MATERIAL = {"name": "dentdemo-plain", "pbrMetallicRoughness": {}}
_GLB_MAGIC, _GLB_JSON, _GLB_BIN = 0x46546C67, 0x4E4F534A, 0x004E4942


@dataclass(frozen=True)
class GltfSource:
    """A glTF file's content as trimesh should read it."""

    data: io.BytesIO
    kind: str  # "glb" or "gltf"
    files: Any  # trimesh's resolver of the external files next to it
    #: Whether its geometry is only there Draco-compressed.
    draco: bool


def gltf_source(path: Path, shown: str) -> GltfSource | None:
    """For a glTF file (.glb, .gltf): its content for trimesh, with a plain material given to
    every primitive that has TEXCOORD_0 and no material, so that trimesh keeps those
    coordinates; None for any other file. Geometry compressed in a way that cannot be decoded
    here is a clear error naming the extension."""
    suffix = path.suffix.lower()
    if suffix not in (".glb", ".gltf"):
        return None
    data = path.read_bytes()
    if suffix == ".glb":
        chunks = _glb_chunks(data, shown)
        document = _json(chunks.get(_GLB_JSON, b""), shown)
    else:
        document = _json(data, shown)
    draco = _check_compression(document, shown)
    if _give_plain_material(document):
        text = json.dumps(document).encode()
        if suffix == ".glb":
            data = _glb(text, chunks.get(_GLB_BIN))
        else:
            data = text
    import trimesh

    files = trimesh.resolvers.FilePathResolver(str(path.parent))
    return GltfSource(io.BytesIO(data), suffix[1:], files, draco)


def _glb_chunks(data: bytes, shown: str) -> dict[int, bytes]:
    """The chunks of a binary glTF by type (JSON, BIN), after its 12-byte header."""
    if len(data) < 20 or struct.unpack_from("<I", data)[0] != _GLB_MAGIC:
        raise DentdemoError(f"{shown}: cannot load mesh (not a binary glTF file)")
    chunks: dict[int, bytes] = {}
    offset = 12
    while offset + 8 <= len(data):
        length, kind = struct.unpack_from("<II", data, offset)
        chunks.setdefault(kind, data[offset + 8 : offset + 8 + length])
        offset += 8 + length
    return chunks


def _glb(text: bytes, binary: bytes | None) -> bytes:
    """A binary glTF of a JSON chunk and an optional BIN chunk (each padded to 4 bytes)."""
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), _GLB_JSON) + text
    if binary is not None:
        binary += b"\0" * (-len(binary) % 4)
        body += struct.pack("<II", len(binary), _GLB_BIN) + binary
    return struct.pack("<III", _GLB_MAGIC, 2, 12 + len(body)) + body


def _json(text: bytes, shown: str) -> dict:
    try:
        document = json.loads(text)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DentdemoError(f"{shown}: cannot load mesh (glTF JSON: {exc})") from None
    if not isinstance(document, dict):
        raise DentdemoError(f"{shown}: cannot load mesh (glTF JSON is not an object)")
    return document


def _primitives(document: dict) -> list[dict]:
    meshes = document.get("meshes")
    return [
        p
        for m in (meshes if isinstance(meshes, list) else [])
        if isinstance(m, dict) and isinstance(m.get("primitives"), list)
        for p in m["primitives"]
        if isinstance(p, dict)
    ]


def _check_compression(document: dict, shown: str) -> bool:
    """Whether the geometry is only there Draco-compressed (trimesh decodes it with DracoPy, a
    dependency: a clear error if that is missing). Meshoptimizer compression is a clear error."""
    required = document.get("extensionsRequired")
    names = set(required) if isinstance(required, list) else set()
    accessors = document.get("accessors")
    accessors = accessors if isinstance(accessors, list) else []
    for primitive in _primitives(document):
        extensions = primitive.get("extensions")
        if not isinstance(extensions, dict) or DRACO not in extensions:
            continue
        # Without an uncompressed fallback the accessors have no bufferView.
        attributes = primitive.get("attributes")
        position = attributes.get("POSITION") if isinstance(attributes, dict) else None
        if not (isinstance(position, int) and 0 <= position < len(accessors)):
            names.add(DRACO)
        elif "bufferView" not in accessors[position]:
            names.add(DRACO)
    if MESHOPT in names:
        raise DentdemoError(
            f"{shown}: its buffers are compressed with {MESHOPT}, which dentdemo cannot decode; "
            "export it again without it"
        )
    if DRACO in names:
        try:
            import DracoPy  # noqa: F401  (trimesh's glTF loader decodes with it)
        except ImportError:
            raise DentdemoError(
                f"{shown}: its geometry is compressed with {DRACO}, and DracoPy, the dentdemo "
                "dependency that decodes it, is not installed (pip install DracoPy)"
            ) from None
    return DRACO in names


def _give_plain_material(document: dict) -> bool:
    """Give primitives with TEXCOORD_0 and no material a plain one; whether any was changed."""
    bare = [
        p
        for p in _primitives(document)
        if "material" not in p and "TEXCOORD_0" in (p.get("attributes") or {})
    ]
    if not bare:
        return False
    materials = document.setdefault("materials", [])
    if not isinstance(materials, list):
        return False
    for primitive in bare:
        primitive["material"] = len(materials)
    materials.append(dict(_PLAIN_MATERIAL))
    return True


def mesh_from_trimesh(loaded: object, name: str = "trimesh mesh", scale: float = 1.0) -> Mesh:
    """A Mesh from a trimesh.Trimesh: its vertices, faces, texture coordinates (kept where they
    are a unique atlas) and base-colour image; `Mesh.source_vertex` indexes `loaded.vertices`."""
    vertices = np.asarray(loaded.vertices, dtype=np.float64)  # type: ignore[attr-defined]
    visual_uv = getattr(getattr(loaded, "visual", None), "uv", None)
    uv = None
    if visual_uv is not None:
        uv = np.asarray(visual_uv, dtype=np.float64)
        # One finite (u, v) per vertex, else none usable (re-atlased as missing).
        if uv.ndim != 2 or len(uv) != len(vertices) or uv.shape[1] < 2:
            uv = None
        elif not np.isfinite(uv[:, :2]).all():
            uv = None
        else:
            uv = uv[:, :2]
    return mesh_from_triangles(
        vertices * scale,
        np.asarray(loaded.faces),  # type: ignore[attr-defined]
        uv,
        name=name,
        scale=scale,
        base_colour_image=_base_colour_image(loaded),
    )


def _base_colour_image(loaded: object) -> NDArray[np.uint8] | None:
    """The base-colour texture of an OBJ/MTL (map_Kd) or glTF (baseColorTexture) mesh, as
    uint8 RGBA rows top-down; None when it has none."""
    material = getattr(getattr(loaded, "visual", None), "material", None)
    image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
    if image is None:
        return None
    try:
        return np.asarray(image.convert("RGBA"), dtype=np.uint8)
    except (OSError, ValueError) as exc:
        raise DentdemoError(f"cannot read the mesh's texture ({exc})") from None


def _points(name: str, what: str, value: object, columns: int) -> NDArray[Any]:
    """`value` as an (n, columns) float64 array of finite numbers, or an error naming it."""
    try:
        data = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        data = np.zeros((0, 0))
    if data.ndim != 2 or data.shape[1] != columns or len(data) == 0:
        shown = f"shape {data.shape}" if data.size else repr(value)
        raise ArgumentError(f"{name}: {what} must be an (n, {columns}) array, got {shown}")
    if not np.isfinite(data).all():
        raise ArgumentError(f"{name}: {what} are not finite (NaN or infinity)")
    return data


def mesh_from_triangles(
    positions: ArrayLike,
    indices: ArrayLike,
    uvs: ArrayLike | None = None,
    name: str = "mesh",
    scale: float = 1.0,
    base_colour_image: NDArray[np.uint8] | None = None,
) -> Mesh:
    """A Mesh from triangles (positions (n, 3) metres, indices (m, 3)) and optional texture
    coordinates (n, 2), kept when they are a unique atlas in [0, 1]; re-atlased (with one
    warning) when missing, tiled or overlapping, as the carve needs a unique atlas. Vertices are
    split along seams and creases: `Mesh.source_vertex` gives each new vertex's index into
    `positions`. `name` names the mesh in messages. A base-colour image keeps being sampled at
    the given coordinates (`Mesh.texture_uvs`)."""
    points = _points(name, "positions", positions, 3)
    if np.asarray(indices).size == 0:
        raise ArgumentError(f"{name}: no triangles found")
    triangles = check_indices(f"{name}: indices", indices, len(points)).astype(np.uint32)
    coords: NDArray[Any] | None = None
    if uvs is not None:
        coords = _points(name, "uvs", uvs, 2)
        if len(coords) != len(points):
            raise ArgumentError(
                f"{name}: uvs must have one row per position ({len(points)}), got {len(coords)}"
            )
    tri = points[triangles]
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1) / 2
    if not (area > 1e-14).any():  # before any warning: a rejected mesh prints one line only
        raise ArgumentError(
            f"{name}: every triangle has no area at scale {scale:g} (too small to draw or carve)"
        )
    # Normals smooth across UV seams and unwelded triangles, hard above the crease angle.
    normals, triangles, source = smooth_normals(points, triangles)
    if coords is not None:
        coords = coords[source]
    points = points[source]
    report = check_uvs(coords, triangles, points)
    texture_uvs = coords if base_colour_image is not None else None
    if not report.ok or coords is None:  # (no coordinates: report.ok is False)
        warnings.warn(
            f"{name}: texture coordinates are {report.describe()}; re-atlasing", stacklevel=2
        )
        try:
            points, normals, new_coords, triangles, kept = reatlas(
                points, triangles, normals, return_mapping=True
            )
        except AtlasFailure as exc:
            raise ArgumentError(
                f"{name}: making texture coordinates for its {len(triangles)} triangles: {exc}; "
                "give the mesh a unique UV atlas of its own"
            ) from None
        if texture_uvs is not None:
            texture_uvs = texture_uvs[kept]
        coords = new_coords
        source = source[kept]
    if base_colour_image is not None and texture_uvs is None:
        base_colour_image = None  # an image without coordinates to sample it by
    mesh = Mesh(
        Path(name).stem,
        points.astype(np.float32),
        normals.astype(np.float32),
        coords.astype(np.float32),
        triangles,
        base_colour_image=base_colour_image,
        texture_uvs=None if texture_uvs is None else texture_uvs.astype(np.float32),
        source_vertex=source,
    )
    if len(mesh.indices) == 0:
        raise ArgumentError(
            f"{name}: every triangle has no area at scale {scale:g} (too small to draw or carve)"
        )
    return mesh
