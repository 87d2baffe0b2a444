"""What one frame shows, described for the renderer: the things to draw with their poses and maps,
the camera, the light and the overlays. The app describes a frame; the renderer only draws it."""

from __future__ import annotations

from dataclasses import dataclass, field

import moderngl
import numpy as np
from numpy.typing import NDArray

from dentdemo.gpu.maps import SurfaceMaps
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.model.materials import Appearance
from dentdemo.model.scene import LightSpec
from dentdemo.render.camera import Camera


@dataclass
class RenderOptions:
    """What to draw. Every field is a toggle of the panel or the keys."""

    parallax: bool = False
    #: 0 shaded, 1 height map, 2 normal map.
    view: int = 0
    wireframe: bool = False
    contacts: bool = False
    address_map: bool = False
    shadows: bool = True
    #: The height view's full-scale dent depth (the legend's top), metres.
    legend_depth: float = 0.005
    #: Move surfaces by their height maps where dents are deep (render/displacement.py).
    displace: bool = True


@dataclass(frozen=True)
class MeshLevel:
    """A coarser render mesh of a DrawItem's surface, with the same texture addresses."""

    mesh: GpuMesh
    #: Largest distance between its triangles and the true surface, metres.
    error: float


@dataclass(frozen=True)
class DrawItem:
    """A mesh at a pose (world from local, metres), shaded with `look` and its maps (None:
    flat)."""

    mesh: GpuMesh
    model: NDArray[np.float64]
    look: Appearance
    maps: SurfaceMaps | None = None
    #: The mesh's own base-colour image (it replaces the look's base colour), or None.
    texture: moderngl.Texture | None = None
    #: Coarser meshes of the same surface, finest first: each pass draws the coarsest whose
    #: error stays under half a pixel of that pass.
    coarser: tuple[MeshLevel, ...] = ()


@dataclass(frozen=True)
class Inset:
    """A texture shown in a corner (the last hit's address map): `extent` pixels of it in use."""

    texture: moderngl.Texture
    extent: tuple[int, int]


@dataclass(frozen=True)
class FrameDescription:
    items: list[DrawItem]
    camera: Camera
    light: LightSpec
    options: RenderOptions
    #: Height of the checkered ground plane, world y metres (None: no ground).
    ground_y: float | None = 0.0
    #: Debug lines, (n, 6) float32 rows: position (world m), colour (linear RGB); pairs.
    lines: NDArray[np.float32] = field(default_factory=lambda: np.zeros((0, 6), np.float32))
    inset: Inset | None = None
    #: A plain background instead of the sky: sRGB in [0, 1], written with alpha 0 (None: sky).
    background: tuple[float, float, float] | None = None
