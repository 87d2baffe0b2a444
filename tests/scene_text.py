"""Scene and materials files for tests, as TOML text: the ground, a plate and a ball, each a
`[[body]]` table, and a steel-like materials table (numbers as assets/materials.toml's steel)."""

from __future__ import annotations

GROUND = """[[body]]
id = "ground"
shape = "plane"
material = "oak"
"""


def camera(eye: str, target: str = "[0.0, 0.0, 0.0]") -> str:
    return f"[camera]\neye = {eye}\ntarget = {target}\n"


def plate(material: str, side: float = 0.4, texels: int | None = None) -> str:
    """A static plate 2 cm thick whose top face is at y = 0.02 m."""
    text = (
        f'[[body]]\nid = "plate"\nshape = "plate"\nside = {side}\nthickness = 0.02\n'
        f'material = "{material}"\nposition = [0.0, 0.02, 0.0]\nstatic = true\n'
    )
    return text + (f"texels_per_metre = {texels}\n" if texels else "")


def ball(material: str, position: str, radius: object = 0.04, texels: int | None = None) -> str:
    text = (
        f'[[body]]\nid = "ball"\nshape = "sphere"\nradius = {radius}\n'
        f'material = "{material}"\nposition = {position}\n'
    )
    return text + (f"texels_per_metre = {texels}\n" if texels else "")


GRAVITY = "[physics]\ngravity = [0.0, -9.81, 0.0]\n"


def steel_like(name: str, max_dent_depth: float, extra: str = "") -> str:
    """A materials table with steel's moduli and density, no bounce (restitution 0)."""
    return (
        f"[materials.{name}]\nyoungs_modulus_Pa = 200e9\nyield_stress_Pa = 250e6\n"
        "plastic_modulus_Pa = 2.0e9\ndensity_kg_m3 = 7850\nrestitution = 0.0\nfriction = 0.5\n"
        f"{extra}max_dent_depth_m = {max_dent_depth}\n"
    )


#: A valid materials table, as a user would write one.
TIN = """[materials.tin]
youngs_modulus_Pa = 50e9
yield_stress_Pa = 10e6
plastic_modulus_Pa = 0.5e9
density_kg_m3 = 7300
restitution = 0.3
friction = 0.5
max_dent_depth_m = 0.02
"""
