"""The paper's impulse and dent-depth equations (eqs. 2, 4, 5), vectorised with numpy.

Conventions: the contact normal N points from body A towards body B (unit length).
Velocities in m/s, inverse masses in 1/kg (0 for a static body), impulses in N*s, depths in m.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def normal_impulse(
    normal: ArrayLike,
    vel_a: ArrayLike,
    vel_b: ArrayLike,
    inv_mass_a: ArrayLike,
    inv_mass_b: ArrayLike,
    restitution: ArrayLike,
) -> NDArray[np.float64]:
    """Paper eq. 2: |J| = -(1 + eps) (N . (v_B - v_A)) / (1/m_A + 1/m_B), in N*s.

    `restitution` is the pair's eps (min(eps_A, eps_B) for eq. 2, 1 for j_{eps=1}).
    Separating or resting pairs (N . (v_B - v_A) >= 0) and two static bodies give 0.
    Shapes broadcast: normal and velocities (..., 3), the rest (...).
    """
    n = np.asarray(normal, dtype=np.float64)
    rel = np.asarray(vel_b, dtype=np.float64) - np.asarray(vel_a, dtype=np.float64)
    approach = np.einsum("...i,...i->...", n, rel)  # m/s, negative when approaching
    inv_sum = np.asarray(inv_mass_a, dtype=np.float64) + np.asarray(inv_mass_b, dtype=np.float64)
    eps = np.asarray(restitution, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        j = -(1.0 + eps) * approach / inv_sum
    return np.where((approach < 0.0) & (inv_sum > 0.0), j, 0.0)


def pair_impulses(
    normal: ArrayLike,
    vel_a: ArrayLike,
    vel_b: ArrayLike,
    inv_mass_a: ArrayLike,
    inv_mass_b: ArrayLike,
    eps_a: ArrayLike,
    eps_b: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(j, j_{eps=1}) magnitudes in N*s: eq. 2 with eps = min(eps_A, eps_B), and with eps = 1."""
    eps = np.minimum(np.asarray(eps_a, dtype=np.float64), np.asarray(eps_b, dtype=np.float64))
    j = normal_impulse(normal, vel_a, vel_b, inv_mass_a, inv_mass_b, eps)
    j1 = normal_impulse(normal, vel_a, vel_b, inv_mass_a, inv_mass_b, 1.0)
    return j, j1


def dent_depth(
    j_elastic: ArrayLike, k: ArrayLike, threshold: ArrayLike, max_dent_depth: ArrayLike
) -> NDArray[np.float64]:
    """Paper eq. 4 with the material's bound, in m:
    delta = min(max_depth, k * max(0, |j_{eps=1}| - Y))."""
    excess = np.maximum(0.0, np.abs(np.asarray(j_elastic, dtype=np.float64)) - threshold)
    return np.minimum(np.asarray(max_dent_depth, dtype=np.float64), np.asarray(k) * excess)
