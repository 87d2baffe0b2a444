"""How materials look: linear albedo, specular strength and Blinn-Phong exponent per preset."""

from __future__ import annotations

LOOKS: dict[str, tuple[tuple[float, float, float], float, float]] = {
    "steel": ((0.42, 0.44, 0.47), 0.9, 64.0),
    "aluminium": ((0.70, 0.71, 0.73), 0.8, 48.0),
    "copper": ((0.72, 0.33, 0.18), 0.9, 64.0),
    "brass": ((0.68, 0.52, 0.20), 0.9, 64.0),
    "lead": ((0.30, 0.32, 0.36), 0.35, 16.0),
    "oak": ((0.45, 0.29, 0.14), 0.15, 12.0),
    "clay": ((0.65, 0.30, 0.20), 0.05, 8.0),
    "rubber": ((0.10, 0.10, 0.11), 0.2, 16.0),
}
DEFAULT_LOOK = ((0.5, 0.5, 0.5), 0.4, 24.0)
GROUND_LOOK = ((0.42, 0.45, 0.40), 0.05, 8.0)


def look(material: str) -> tuple[tuple[float, float, float], float, float]:
    return LOOKS.get(material, DEFAULT_LOOK)
