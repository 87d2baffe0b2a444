"""Rigid poses: a unit quaternion (w, x, y, z) as a rotation matrix, and a body's pose
(origin in metres, quaternion) as its world-from-local 4x4 (column vectors). Used by physics,
and by the hit log, whose replay must build the very matrices the carve was given."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def quat_to_matrix(q: NDArray[np.float64]) -> NDArray[np.float64]:
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def pose_matrix(position: ArrayLike, quaternion: ArrayLike) -> NDArray[np.float64]:
    """World from body-local 4x4 (column vectors) of a pose: the origin's position (m) and the
    quaternion (w, x, y, z)."""
    m = np.eye(4)
    m[:3, :3] = quat_to_matrix(np.asarray(quaternion, dtype=np.float64))
    m[:3, 3] = np.asarray(position, dtype=np.float64)
    return m
