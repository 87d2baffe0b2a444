"""The debug views' legends, drawn once per view and scale with Pillow into a texture: the height
view's colour ramp labelled in millimetres (the ramp's stops are depth_ramp.glsl's), and what the
normal view's colours mean."""

from __future__ import annotations

import moderngl
import numpy as np
from PIL import Image, ImageDraw

#: depth_ramp.glsl's stops, sRGB.
RAMP = np.array(
    [
        (0.88, 0.88, 0.88),
        (0.20, 0.40, 0.85),
        (0.10, 0.70, 0.60),
        (0.95, 0.85, 0.20),
        (0.85, 0.15, 0.10),
    ]
)
SIZE = (220, 64)  # pixels


def ramp(t: np.ndarray) -> np.ndarray:
    """The ramp at t in [0, 1] (sRGB, as the shader mixes it)."""
    x = np.clip(t, 0.0, 1.0) * (len(RAMP) - 1)
    i = np.minimum(np.floor(x).astype(int), len(RAMP) - 2)
    f = (x - i)[..., None]
    return RAMP[i] * (1 - f) + RAMP[i + 1] * f


def legend_image(view: int, full_scale_m: float) -> np.ndarray:
    """RGBA uint8 rows top-down."""
    image = Image.new("RGBA", SIZE, (20, 20, 24, 220))
    draw = ImageDraw.Draw(image)
    if view == 1:
        bar = (ramp(np.linspace(0, 1, SIZE[0] - 20)) * 255).astype(np.uint8)
        strip = Image.fromarray(np.repeat(bar[None], 16, axis=0), "RGB")
        image.paste(strip, (10, 22))
        draw.text((10, 4), "dent depth (mm)", fill=(235, 235, 235, 255))
        for k in range(5):
            x = 10 + k * (SIZE[0] - 21) // 4
            draw.line([x, 38, x, 42], fill=(235, 235, 235, 255))
            label = f"{full_scale_m * 1e3 * k / 4:g}"
            draw.text((max(x - 3 * len(label), 2), 44), label, fill=(235, 235, 235, 255))
    else:
        draw.text((10, 6), "normal map, tangent space", fill=(235, 235, 235, 255))
        draw.text((10, 24), "R = along +u, G = along +v", fill=(235, 235, 235, 255))
        draw.text((10, 42), "B = out of the surface", fill=(235, 235, 235, 255))
    return np.asarray(image)


def legend_texture(ctx: moderngl.Context, view: int, full_scale_m: float) -> moderngl.Texture:
    rgba = np.ascontiguousarray(legend_image(view, full_scale_m)[::-1])  # row 0 at the bottom
    return ctx.texture(SIZE, 4, rgba.tobytes())
