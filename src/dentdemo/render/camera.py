"""An orbit camera and the matrices of the renderer. Column-vector convention (p' = M p), world
space in metres; uploaded to GL as M.T (column-major)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import pyrr
from numpy.typing import ArrayLike, NDArray

Mat4 = NDArray[np.float64]
#: The view's near and far planes, metres from the eye.
NEAR, FAR = 0.02, 50.0


def look_at(eye: ArrayLike, target: ArrayLike, up: ArrayLike = (0.0, 1.0, 0.0)) -> Mat4:
    """View matrix (camera from world)."""
    return np.asarray(
        pyrr.matrix44.create_look_at(
            np.asarray(eye, float), np.asarray(target, float), np.asarray(up, float)
        ),
        dtype=np.float64,
    ).T


def perspective(fov_deg: float, aspect: float, near: float, far: float) -> Mat4:
    return np.asarray(
        pyrr.matrix44.create_perspective_projection(fov_deg, aspect, near, far), dtype=np.float64
    ).T


def orthographic(half_width: float, half_height: float, near: float, far: float) -> Mat4:
    return np.asarray(
        pyrr.matrix44.create_orthogonal_projection(
            -half_width, half_width, -half_height, half_height, near, far
        ),
        dtype=np.float64,
    ).T


class Camera(Protocol):
    """What the renderer asks of a camera (world metres)."""

    @property
    def eye(self) -> NDArray[np.float64]: ...

    @property
    def target(self) -> NDArray[np.float64]: ...

    def view_proj(self, aspect: float) -> Mat4: ...

    def pixels_per_metre(self, rows: int) -> float:
        """Pixels per metre across the view at clip w = 1, for an image `rows` pixels high."""
        ...

    def metres_per_pixel(self, distance: float, rows: int) -> float:
        """A pixel's width, metres, at `distance` metres from the eye."""
        ...


@dataclass
class OrbitCamera:
    """Orbits `target` at `distance`; yaw about +Y, pitch above the horizon, both in radians."""

    target: NDArray[np.float64]
    distance: float
    yaw: float
    pitch: float
    fov_deg: float = 45.0

    @classmethod
    def from_eye(cls, eye: ArrayLike, target: ArrayLike, fov_deg: float = 45.0) -> OrbitCamera:
        offset = np.asarray(eye, float) - np.asarray(target, float)
        distance = float(np.linalg.norm(offset))
        return cls(
            np.asarray(target, float),
            distance,
            math.atan2(offset[0], offset[2]),
            math.asin(offset[1] / distance),
            fov_deg,
        )

    @property
    def eye(self) -> NDArray[np.float64]:
        c = math.cos(self.pitch)
        return self.target + self.distance * np.array(
            [c * math.sin(self.yaw), math.sin(self.pitch), c * math.cos(self.yaw)]
        )

    def view(self) -> Mat4:
        return look_at(self.eye, self.target)

    def projection(self, aspect: float) -> Mat4:
        return perspective(self.fov_deg, aspect, NEAR, FAR)

    def view_proj(self, aspect: float) -> Mat4:
        return self.projection(aspect) @ self.view()

    def pixels_per_metre(self, rows: int) -> float:
        """At clip w = 1, i.e. one metre ahead of the eye (w is the distance along the view)."""
        return rows / (2.0 * np.tan(np.radians(self.fov_deg) / 2))

    def metres_per_pixel(self, distance: float, rows: int) -> float:
        return 2.0 * np.tan(np.radians(self.fov_deg) / 2) / rows * distance

    def orbit(self, d_yaw: float, d_pitch: float) -> None:
        self.yaw += d_yaw
        self.pitch = float(np.clip(self.pitch + d_pitch, -1.45, 1.45))

    def zoom(self, factor: float) -> None:
        self.distance = float(np.clip(self.distance * factor, 0.1, 40.0))

    def pan(self, dx: float, dy: float) -> None:
        """Move the target in the view plane by fractions of the distance."""
        view = self.view()
        right, up = view[0, :3], view[1, :3]
        self.target = self.target + (-dx * right + dy * up) * self.distance

    def ray(self, ndc_x: float, ndc_y: float, aspect: float) -> tuple[NDArray, NDArray]:
        """World ray (origin, unit direction) through a point in normalized device coordinates."""
        inverse = np.linalg.inv(self.view_proj(aspect))
        near = inverse @ np.array([ndc_x, ndc_y, -1.0, 1.0])
        far = inverse @ np.array([ndc_x, ndc_y, 1.0, 1.0])
        a, b = near[:3] / near[3], far[:3] / far[3]
        return a, (b - a) / np.linalg.norm(b - a)

    def project(self, points: NDArray, aspect: float, size: tuple[int, int]) -> NDArray[np.float64]:
        """Pixel coordinates (x right, y down from the top) of world points."""
        p = np.atleast_2d(points)
        clip = np.hstack([p, np.ones((len(p), 1))]) @ self.view_proj(aspect).T
        ndc = clip[:, :3] / clip[:, 3:4]
        return np.stack([(ndc[:, 0] + 1) / 2 * size[0], (1 - ndc[:, 1]) / 2 * size[1]], axis=1)


@dataclass
class SideCamera:
    """An orthographic view of `target` from `eye` with `up` pointing up and `half_height`
    metres from the centre of the image to its top edge (so sizes can be measured in pixels)."""

    eye: NDArray[np.float64]
    target: NDArray[np.float64]
    up: NDArray[np.float64]
    half_height: float

    def view_proj(self, aspect: float) -> Mat4:
        reach = float(np.linalg.norm(self.target - self.eye))
        near, far = max(reach - 4.0 * self.half_height, NEAR), reach + 4.0 * self.half_height
        projection = orthographic(self.half_height * aspect, self.half_height, near, far)
        return projection @ look_at(self.eye, self.target, self.up)

    def pixels_per_metre(self, rows: int) -> float:
        """Everywhere (clip w is 1 in an orthographic view)."""
        return rows / (2.0 * self.half_height)

    def metres_per_pixel(self, distance: float, rows: int) -> float:
        return 2.0 * self.half_height / rows
