"""Looks the renderer uses besides the materials' own (model.materials.Appearance)."""

from __future__ import annotations

from dentdemo.model.materials import SURFACES, Appearance

#: The checkered ground: a matte, slightly green grey.
GROUND = Appearance(base_colour=(0.32, 0.34, 0.30), metalness=0.0, roughness=0.85)


def surface_code(appearance: Appearance) -> int:
    """The integer surface_detail.glsl switches on (the index in SURFACES)."""
    return SURFACES.index(appearance.surface)
