"""Meshes from files (OBJ, glTF, PLY, STL... through trimesh), with a check that the texture
coordinates are a unique atlas and an automatic re-atlas (xatlas) where they are not."""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dentdemo.errors import DentdemoError
from dentdemo.mesh.mesh import Mesh
from dentdemo.mesh.normals import smooth_normals

#: Resolution of the raster used to find overlapping UV triangles.
OVERLAP_GRID = 256
#: Padding between xatlas charts, in texels of its packing resolution.
ATLAS_PADDING = 4
ATLAS_RESOLUTION = 1024


@dataclass(frozen=True)
class UVReport:
    """What is wrong with a mesh's texture coordinates, if anything."""

    missing: bool = False
    tiled: bool = False  # coordinates outside [0, 1]
    overlapping: bool = False
    #: Share of sampled atlas cells covered by more than one triangle.
    overlap_fraction: float = 0.0

    @property
    def ok(self) -> bool:
        return not (self.missing or self.tiled or self.overlapping)

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
        return ", ".join(parts) or "unique"


def check_uvs(uvs: NDArray[np.floating] | None, indices: NDArray[np.integer]) -> UVReport:
    """Classify texture coordinates: missing, tiled (outside [0, 1]) or overlapping charts."""
    if uvs is None or len(uvs) == 0:
        return UVReport(missing=True)
    uv = np.asarray(uvs, dtype=np.float64)
    if not np.isfinite(uv).all():
        return UVReport(missing=True)
    eps = 1e-4
    tiled = bool((uv < -eps).any() or (uv > 1 + eps).any())
    fraction = _overlap_fraction(uv, np.asarray(indices).reshape(-1, 3))
    return UVReport(tiled=tiled, overlapping=fraction > 1e-3, overlap_fraction=fraction)


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


def reatlas(
    positions: NDArray, indices: NDArray, normals: NDArray, return_mapping: bool = False
) -> tuple:
    """New unique UVs from xatlas, with gutters between charts; returns (positions, normals, uvs,
    indices) with vertices split along the new seams."""
    import xatlas

    atlas = xatlas.Atlas()
    atlas.add_mesh(
        positions.astype(np.float32), indices.astype(np.uint32), normals.astype(np.float32)
    )
    pack = xatlas.PackOptions()
    pack.padding = ATLAS_PADDING
    pack.resolution = ATLAS_RESOLUTION
    pack.bilinear = True
    atlas.generate(xatlas.ChartOptions(), pack)
    vmapping, new_indices, uvs = atlas[0] if hasattr(atlas, "__getitem__") else atlas.get_mesh(0)
    if return_mapping:  # which input vertex each output vertex copies
        return positions[vmapping], normals[vmapping], uvs, new_indices, vmapping
    return positions[vmapping], normals[vmapping], uvs, new_indices


def load_mesh(path: str | Path, scale: float = 1.0) -> Mesh:
    """Load a triangle mesh file; re-atlas it when its UVs are missing, tiled or overlapping.
    A file is read (and re-atlased, and warned about) once per content and scale: physics and
    drawing share the result."""
    path = Path(path)
    try:
        stat = path.stat()
    except OSError as exc:
        raise DentdemoError(f"{path}: cannot load mesh ({exc.strerror})") from None
    return _load_mesh(path.resolve(), str(path), float(scale), stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=32)
def _load_mesh(resolved: Path, shown: str, scale: float, mtime_ns: int, size: int) -> Mesh:
    """load_mesh's work; the file's time and size in the key make an edited file load anew."""
    import trimesh

    path = Path(shown)
    try:
        loaded = trimesh.load(resolved, force="mesh", process=False)
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
    visual_uv = getattr(getattr(loaded, "visual", None), "uv", None)
    return mesh_from_triangles(
        np.asarray(loaded.vertices, dtype=np.float64) * scale,
        np.asarray(loaded.faces),
        visual_uv,
        name=str(path),
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


def mesh_from_triangles(
    positions: NDArray[np.floating],
    indices: NDArray[np.integer],
    uvs: NDArray[np.floating] | None = None,
    name: str = "mesh",
    scale: float = 1.0,
    base_colour_image: NDArray[np.uint8] | None = None,
) -> Mesh:
    """A Mesh from triangles (positions (n, 3) metres, indices (m, 3)) and optional texture
    coordinates; re-atlased (with one warning) when the coordinates are missing, tiled or
    overlapping, as the carve needs a unique atlas. `name` names the mesh in messages. A
    base-colour image keeps being sampled at the given coordinates (`Mesh.texture_uvs`)."""
    positions = np.asarray(positions, dtype=np.float64)
    indices = np.asarray(indices, dtype=np.uint32).reshape(-1, 3)
    if len(indices) == 0:
        raise DentdemoError(f"{name}: no triangles found")
    if not np.isfinite(positions).all():
        raise DentdemoError(f"{name}: vertex positions are not finite")
    tri = positions[indices]
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1) / 2
    if not (area > 1e-14).any():  # before any warning: a rejected mesh prints one line only
        raise DentdemoError(
            f"{name}: every triangle has no area at scale {scale:g} (too small to draw or carve)"
        )
    # Normals smooth across UV seams and unwelded triangles, hard above the crease angle.
    normals, indices, source = smooth_normals(positions, indices)
    coords = None
    if uvs is not None and len(uvs) == len(positions):  # one uv per vertex, else none usable
        coords = np.asarray(uvs, dtype=np.float64)[source]
    positions = positions[source]
    report = check_uvs(coords, indices)
    texture_uvs = coords if base_colour_image is not None else None
    if not report.ok or coords is None:  # (no coordinates: report.ok is False)
        warnings.warn(
            f"{name}: texture coordinates are {report.describe()}; re-atlasing", stacklevel=2
        )
        positions, normals, new_coords, indices, kept = reatlas(
            positions, indices, normals, return_mapping=True
        )
        if texture_uvs is not None:
            texture_uvs = texture_uvs[kept]
        coords = new_coords
    if base_colour_image is not None and texture_uvs is None:
        base_colour_image = None  # an image without coordinates to sample it by
    mesh = Mesh(
        Path(name).stem,
        positions.astype(np.float32),
        normals.astype(np.float32),
        coords.astype(np.float32),
        indices.astype(np.uint32),
        base_colour_image=base_colour_image,
        texture_uvs=None if texture_uvs is None else texture_uvs.astype(np.float32),
    )
    if len(mesh.indices) == 0:
        raise DentdemoError(
            f"{name}: every triangle has no area at scale {scale:g} (too small to draw or carve)"
        )
    return mesh
