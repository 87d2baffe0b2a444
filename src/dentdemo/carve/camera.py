"""Pass 1: the orthographic collision camera, computed on the CPU from the contact frame.

World space, metres. The camera looks along the press direction (the way the tool moves into the
target). Its right axis follows the target's +u tangent at the contact and its pixel pitch follows
the target's texel pitch there, with the centre snapped to a texel centre: on flat charts every
camera pixel then samples exactly one texel centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dentdemo.mesh.mesh import Mesh

Vec3 = NDArray[np.float64]


@dataclass(frozen=True)
class ContactFrame:
    """Where and which way the tool presses: `point` on the target's surface at first touch (world,
    metres) and `direction`, the unit vector along which the tool moves into the target."""

    point: Vec3
    direction: Vec3


@dataclass(frozen=True)
class CollisionCamera:
    eye: Vec3
    right: Vec3
    up: Vec3
    forward: Vec3
    #: Half width and height of the view, metres.
    half_extent: tuple[float, float]
    #: Near and far distance along `forward` from `eye`, metres.
    depth_range: tuple[float, float]
    #: Pixels (columns, rows); odd, so the central pixel is centred on the snapped contact.
    resolution: tuple[int, int]


def _unit(v: Vec3) -> Vec3:
    return v / max(float(np.linalg.norm(v)), 1e-30)


def collision_camera(
    target: Mesh,
    target_model: NDArray[np.float64],
    map_size: tuple[int, int],
    tool_centre: NDArray[np.float64],
    tool_radius: float,
    contact: ContactFrame,
    max_resolution: int,
    oversample: float | None = None,
) -> CollisionCamera:
    """The camera for carving `target` (pose `target_model`, world from local) around `contact`.

    The tool lies inside the sphere (`tool_centre`, `tool_radius`) (world, metres), which bounds
    its footprint. `oversample` is camera pixels
    per texel along each axis: 1 on flat charts (aligned), 2 on curved ones by default.
    """
    model = np.asarray(target_model, dtype=np.float64)
    linear = model[:3, :3]
    forward = _unit(np.asarray(contact.direction, dtype=np.float64))
    point = np.asarray(contact.point, dtype=np.float64)
    local = np.linalg.solve(linear, point - model[:3, 3])
    surf = target.surface_at(local)
    dpdu, dpdv = linear @ surf.dpdu, linear @ surf.dpdv  # world metres per uv unit
    width, height = map_size

    right = dpdu - (dpdu @ forward) * forward
    if np.linalg.norm(right) < 1e-9 * max(np.linalg.norm(dpdu), 1e-30):
        helper = np.array([1.0, 0.0, 0.0]) if abs(forward[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
        right = helper - (helper @ forward) * forward
    right = _unit(right)
    up = np.cross(right, forward)

    # Texel pitch seen by the camera, metres; grazing views are clamped to a fifth of a texel.
    texel_u = np.linalg.norm(dpdu) / width
    texel_v = np.linalg.norm(dpdv) / height
    pitch_x = max(abs(dpdu @ right) / width, 0.2 * texel_u)
    pitch_y = max(abs(dpdv @ up) / height, 0.2 * texel_v)
    factor = oversample if oversample is not None else (2.0 if target.curved else 1.0)
    pitch_x, pitch_y = pitch_x / factor, pitch_y / factor

    # Snap the view axis to the centre of the texel under the contact.
    uv = surf.uv
    centre_uv = (np.floor(uv * [width, height]) + 0.5) / [width, height]
    snapped = point + dpdu * (centre_uv[0] - uv[0]) + dpdv * (centre_uv[1] - uv[1])

    # The overlap lies inside both bounding spheres: the view covers the smaller one's circle.
    offset = np.asarray(tool_centre, dtype=np.float64) - snapped
    target_centre = model[:3, 3] - snapped
    target_radius = target.bounding_radius * float(np.linalg.norm(linear, ord=2))

    def circle(rel: Vec3, radius: float) -> float:
        return max(abs(rel @ right), abs(rel @ up)) + radius * 1.02

    half = min(circle(offset, tool_radius), circle(target_centre, target_radius))
    half += max(pitch_x, pitch_y)
    cols = min(2 * math.ceil(half / pitch_x) + 1, max_resolution - (1 - max_resolution % 2))
    rows = min(2 * math.ceil(half / pitch_y) + 1, max_resolution - (1 - max_resolution % 2))
    half_x, half_y = cols * pitch_x / 2, rows * pitch_y / 2
    if cols * pitch_x < 2 * half:  # capped: fewer, larger pixels cover the footprint
        half_x = half
    if rows * pitch_y < 2 * half:
        half_y = half

    reach = max(0.0, -(offset @ forward)) + 1.01 * tool_radius + 1e-4
    eye = snapped - forward * reach
    far = reach + 2.0 * tool_radius + 2.0 * target.bounding_radius + 1e-3
    return CollisionCamera(
        eye=eye,
        right=right,
        up=up,
        forward=forward,
        half_extent=(float(half_x), float(half_y)),
        depth_range=(0.0, float(far)),
        resolution=(int(cols), int(rows)),
    )
