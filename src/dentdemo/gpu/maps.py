"""The maps of one body on the GPU: what the carve writes and the renderer samples."""

from __future__ import annotations

from dataclasses import dataclass

import moderngl

from dentdemo.gl.context import release


@dataclass
class SurfaceMaps:
    """The maps of one body. Heights in metres along the surface normal (0 pristine, < 0 dent)."""

    height: moderngl.Texture
    normal: moderngl.Texture
    mask: moderngl.Texture
    #: Surface length of one texel along +u and +v, metres.
    texel_metres: tuple[float, float]
    #: Deepest height the map may hold is -max_dent_depth, metres.
    max_dent_depth: float
    height_fbo: moderngl.Framebuffer
    normal_fbo: moderngl.Framebuffer
    #: No height in the map is above this, metres (>= 0; bumps of a start map stand proud). Carves
    #: only lower heights, so it changes only when a map is loaded.
    max_height: float = 0.0

    @property
    def size(self) -> tuple[int, int]:
        return self.height.size

    def release(self) -> None:
        release(self.height_fbo, self.normal_fbo, self.height, self.normal, self.mask)
