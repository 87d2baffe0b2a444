"""The panel's live view of the selected body's maps: its height map coloured by depth (a small
pass into an RGBA8 texture the panel shows), and its normal map as it is. All on the GPU: nothing
is read back."""

from __future__ import annotations

import math

import moderngl

from dentdemo.gl.context import GLContext
from dentdemo.gl.passes import Pass, PassState
from dentdemo.gl.shaders import program
from dentdemo.gl.state import preserved
from dentdemo.gpu.maps import SurfaceMaps

#: Side of the height view's texture, pixels.
VIEW_SIZE = 256
#: Most map texels per view pixel along an axis: every texel of a map up to 4096 texels a side
#: is read; a larger one would show every 16 x 16 block's first texels only.
MAX_BLOCK = 16


class MapView:
    """Owns the height view's texture; `update` redraws it from a body's maps."""

    def __init__(self, gl: GLContext) -> None:
        self.gl = gl
        ctx = gl.ctx
        self.texture = ctx.texture((VIEW_SIZE, VIEW_SIZE), 4, dtype="f1")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._fbo = ctx.framebuffer([self.texture])
        self._pass = Pass(
            "height view",
            program(gl.cache, ctx, "util/fullscreen.vert", "app/height_view.frag"),
            PassState(),
            samplers=("u_height",),
        )
        self._vao = ctx.vertex_array(self._pass.program, [])

    def update(self, maps: SurfaceMaps, full_scale: float) -> moderngl.Texture:
        """Draw `maps`' heights (depth `full_scale` metres at the ramp's top) into `texture`."""
        block = min(MAX_BLOCK, max(1, math.ceil(maps.size[0] / VIEW_SIZE)))
        with preserved(self.gl.ctx):  # the frame's framebuffer and state stay as they were
            self._pass.run(
                self.gl.ctx,
                self._fbo,
                (0, 0, VIEW_SIZE, VIEW_SIZE),
                lambda _: self._vao.render(moderngl.TRIANGLES, vertices=3),
                (maps.height,),
                {"u_full_scale": float(full_scale), "u_block": block},
            )
        return self.texture

    def release(self) -> None:
        self._vao.release()
        self._fbo.release()
        self.texture.release()
