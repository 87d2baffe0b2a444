"""Quality presets: what the renderer spends per frame. `low` is chosen on a software rasteriser
(llvmpipe), where every sample is CPU time; `high` on a GPU."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Quality:
    name: str
    #: Multisample anti-aliasing samples (0: none).
    msaa: int
    #: Side of the sun's shadow map, texels.
    shadow_size: int
    #: Shadow comparisons per pixel (1, or 4 for a 3 x 3 texel filter).
    shadow_taps: int
    #: Shaded pixels per output pixel, per axis (the frame is stretched bilinearly to the output).
    #: On a software rasteriser the body shading's cost follows the shaded pixels; low's 0.45
    #: still shows the 1 mm close-up dent (tests/test_look.py).
    render_scale: float = 1.0
    #: Procedural surface detail (brushed, cast, grain) in the shading.
    surface_detail: bool = True
    #: Displacement (render/displacement.py): a dent (or bump) at least this many pixels deep
    #: moves the surface; shallower ones stay in the normal map and parallax.
    deep_pixels: float = 0.25
    #: Where it moves, edges are cut into segments of about this many pixels...
    segment_pixels: float = 2.0
    #: ...but into no more than this many (the tessellation level; GL guarantees 64). 1: no cuts,
    #: the drawn mesh's own vertices move (no tessellation stages, which cost llvmpipe far more
    #: per patch than moving vertices does: docs/performance.md).
    max_segments: int = 64


PRESETS = {
    "low": Quality(
        "low",
        msaa=0,
        shadow_size=1024,
        shadow_taps=1,
        render_scale=0.45,
        surface_detail=False,
        deep_pixels=1.0,
        segment_pixels=8.0,
        max_segments=1,
    ),
    "medium": Quality(
        "medium",
        msaa=2,
        shadow_size=2048,
        shadow_taps=4,
        render_scale=0.75,
        deep_pixels=0.5,
        segment_pixels=4.0,
        max_segments=32,
    ),
    "high": Quality(
        "high",
        msaa=4,
        shadow_size=2048,
        shadow_taps=4,
        deep_pixels=0.25,
        segment_pixels=2.0,
        max_segments=64,
    ),
}


def preset(name: str | None, software: bool) -> Quality:
    """The named preset; None picks `low` on a software rasteriser and `high` elsewhere."""
    if name is None:
        return PRESETS["low" if software else "high"]
    return PRESETS[name]
