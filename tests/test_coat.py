"""A coat of paint (issue 44): where a dent or a scratch is deeper than the coat, the material
under it shows; elsewhere the coat. Held in the renderer to the analytic disc where a pressed
ball's cap is deeper than the coat, and in the glTF export's textures texel by texel."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from closeup_helpers import ALUMINIUM, DEPTH, RADIUS, camera, footprint_mask, render_closeup
from dentdemo.model.materials import Appearance, load_materials
from dentdemo.render.frame import RenderOptions

RED = (0.6, 0.02, 0.02)


def _shrunk(mask: np.ndarray, pixels: int) -> np.ndarray:
    """`mask` less a band `pixels` wide at its edge (the rim's antialiased pixels)."""
    out = mask.copy()
    for axis in (0, 1):
        for shift in (-pixels, pixels):
            out &= np.roll(mask, shift, axis=axis)
    return out


@pytest.mark.slow
def test_a_dent_deeper_than_the_coat_shows_the_metal(gl):
    """A 5 cm ball pressed 1 mm into an aluminium plate with a 0.4 mm red coat: bare metal
    (grey: red close to green) inside the disc where the cap is deeper than 0.4 mm, radius
    sqrt(2 R (d - t) - (d - t)^2); red paint in the ring out to the dent's rim and beyond."""
    coat = 0.0004
    look = replace(ALUMINIUM, coat_thickness=coat, coat_colour=RED, coat_roughness=0.5)
    # Undisplaced, so that each pixel sees the plate's plane where the mask's rays meet it.
    flat = RenderOptions(displace=False)
    image = render_closeup(gl, True, flat, look=look).astype(int)
    bare = _shrunk(footprint_mask(camera(), depth=DEPTH - coat), 2)
    painted = _shrunk(~footprint_mask(camera(), depth=DEPTH - coat), 2)
    redness = image[..., 0] - image[..., 1]
    assert bare.sum() > 100 and (redness[bare] < 40).mean() > 0.99
    plate = image.sum(axis=2) > 0  # the plate fills the view's lower part; the sky is bright
    assert (redness[painted & plate] > 60).mean() > 0.95
    # Without a dent the whole plate is painted; a coat thinner than nothing changes nothing.
    plain = render_closeup(gl, False, flat, look=look).astype(int)
    assert ((plain[..., 0] - plain[..., 1])[bare] > 60).all()
    assert (
        render_closeup(gl, True, look=ALUMINIUM)
        == render_closeup(gl, True, look=replace(ALUMINIUM, coat_colour=RED))
    ).all()
    assert math.isclose(RADIUS, 0.05)  # the helpers' ball, which the masks assume


def test_the_gltf_textures_follow_the_same_rule():
    """Texel by texel: the coat's colour and roughness/metalness where height >= -thickness,
    the material's where it is deeper (sRGB bytes by hand: linear 0.6 -> 203, 0.02 -> 39)."""
    from dentdemo.gltf import coat_textures

    look = Appearance(
        base_colour=(1.0, 1.0, 1.0),
        metalness=1.0,
        roughness=0.2,
        coat_thickness=1e-4,
        coat_colour=RED,
        coat_metalness=0.0,
        coat_roughness=0.8,
    )
    height = np.array([[0.0, -0.99e-4, -1e-4, -1.01e-4, -5e-3]], dtype=np.float32)
    colour, metal_rough = coat_textures(look, height)
    coated = [True, True, True, False, False]
    for i, paint in enumerate(coated):
        assert colour[0, i].tolist() == ([203, 39, 39] if paint else [255, 255, 255])
        assert metal_rough[0, i].tolist() == ([0, 204, 0] if paint else [0, 51, 255])
        assert look.coated(float(height[0, i])) == paint


def test_the_painted_preset_and_the_coat_keys():
    lib = load_materials()
    painted = lib.get("painted_steel").appearance
    assert painted.coat_thickness == pytest.approx(1e-4) and painted.metalness == 1.0
    assert painted.coat_metalness == 0.0
    assert all(
        m.appearance.coat_thickness == 0.0 for n, m in lib.materials.items() if n != "painted_steel"
    )


def test_a_coated_part_exports_both_textures():
    from dentdemo.gltf import GltfBody, GltfPart, build
    from dentdemo.mesh.primitives import plate

    look = Appearance(coat_thickness=1e-4, coat_colour=RED)
    height = np.zeros((16, 16), dtype=np.float32)
    height[4:8, 4:8] = -2e-4
    part = GltfPart(plate(0.2), look, None, height, -0.01, "surface")
    document, _ = build([GltfBody("plate", np.eye(4), (part,))])
    pbr = document["materials"][0]["pbrMetallicRoughness"]
    assert {"baseColorTexture", "metallicRoughnessTexture"} <= set(pbr)
    assert pbr["baseColorFactor"] == [1.0, 1.0, 1.0, 1.0] and pbr["metallicFactor"] == 1.0
    # Without a coat: the factors alone, as before.
    plain = GltfPart(plate(0.2), Appearance(), None, height, -0.01, "surface")
    document, _ = build([GltfBody("plate", np.eye(4), (plain,))])
    assert "metallicRoughnessTexture" not in document["materials"][0]["pbrMetallicRoughness"]


def test_a_coated_part_without_dents_exports_the_coat():
    """A plate's sides (no maps): painted all over, as the renderer draws them (height 0)."""
    from dentdemo.gltf import GltfBody, GltfPart, build
    from dentdemo.mesh.primitives import plate

    look = Appearance(base_colour=(0.9, 0.9, 0.9), metalness=1.0, coat_thickness=1e-4)
    look = replace(look, coat_colour=RED, coat_roughness=0.7)
    document, _ = build([GltfBody("plate", np.eye(4), (GltfPart(plate(0.2), look),))])
    pbr = document["materials"][0]["pbrMetallicRoughness"]
    assert pbr["baseColorFactor"] == [*RED, 1.0]
    assert pbr["metallicFactor"] == 0.0 and pbr["roughnessFactor"] == 0.7
