"""The scene renderer: shadow pass, sky, normal-mapped bodies, debug views, MSAA resolve."""

from __future__ import annotations

import moderngl
import numpy as np

from dentdemo.carve.surface import GpuMesh
from dentdemo.gl.context import GLContext, release
from dentdemo.gl.shaders import program
from dentdemo.gl.shaders import set_uniform as _set
from dentdemo.mesh import primitives
from dentdemo.render.camera import NEAR, look_at, orthographic
from dentdemo.render.environment import LEVELS, environment
from dentdemo.render.frame import DrawItem, FrameDescription, Inset, RenderOptions
from dentdemo.render.legend import legend_texture
from dentdemo.render.looks import GROUND, surface_code
from dentdemo.render.quality import Quality, preset

GROUND_SIDE = 12.0  # m
#: Half the side of the square the sun's shadow map covers, around the camera target, m.
LIGHT_HALF_EXTENT = 2.5
#: A coarser mesh is drawn where its chord error stays under this many pixels of the pass.
LEVEL_PIXELS = 0.5
#: Scene-referred scale before the tone curve.
EXPOSURE = 1.0


class Renderer:
    """Draws a FrameDescription into an MSAA framebuffer and resolves it into `output` (sRGB
    bytes). It knows nothing of the simulation: what to draw comes in the description."""

    def __init__(
        self, gl: GLContext, size: tuple[int, int], quality: Quality | None = None
    ) -> None:
        self.gl = gl
        ctx = gl.ctx
        self.size = size
        self.quality = quality or preset(None, gl.software)
        samples = min(self.quality.msaa, ctx.max_samples)
        shadow_size = self.quality.shadow_size
        scale = self.quality.render_scale
        #: Pixels shaded: the output size times the preset's render scale.
        self.shade_size = (max(16, round(size[0] * scale)), max(16, round(size[1] * scale)))
        #: The shaded frame at shade_size, bilinear for the upscale to the output.
        self._resolved = ctx.texture(self.shade_size, 4)
        self._resolved.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self._resolved_fbo = ctx.framebuffer([self._resolved])
        self._msaa_depth = ctx.depth_renderbuffer(self.shade_size, samples=samples)
        #: Where the scene is shaded: multisampled colour (resolved afterwards), or without
        #: multisampling the resolved texture itself (no copy).
        self._msaa_colour = (
            ctx.renderbuffer(self.shade_size, 4, samples=samples) if samples else self._resolved
        )
        self.msaa = ctx.framebuffer([self._msaa_colour], self._msaa_depth)
        self.output_texture = ctx.texture(size, 4)
        self.output = ctx.framebuffer([self.output_texture])
        self._upscale = program(gl.cache, ctx, "util/fullscreen.vert", "render/upscale.frag")
        self._empty_upscale = ctx.vertex_array(self._upscale, [])
        self.shadow_texture = ctx.depth_texture((shadow_size, shadow_size))
        self.shadow_texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.shadow_texture.compare_func = "<="  # hardware comparison: bilinear PCF per tap
        self.shadow = ctx.framebuffer(depth_attachment=self.shadow_texture)
        self._depth = program(gl.cache, ctx, "render/shadow.vert", "render/shadow.frag")
        self._sky = program(
            gl.cache, ctx, "util/fullscreen.vert", "render/sky.frag", defines={"AT_FAR_PLANE": 1}
        )
        self._lines = program(gl.cache, ctx, "render/lines.vert", "render/lines.frag")
        self._overlay = program(gl.cache, ctx, "util/rect.vert", "render/overlay.frag")
        self._empty_sky = ctx.vertex_array(self._sky, [])
        self._empty_rect = ctx.vertex_array(self._overlay, [])
        self._image = program(gl.cache, ctx, "util/rect.vert", "render/image.frag")
        self._empty_image = ctx.vertex_array(self._image, [])
        self._legends: dict[tuple[int, float], moderngl.Texture] = {}
        self._ground = GpuMesh(gl, primitives.plate(GROUND_SIDE, subdivisions=1))
        self._flat_normal = ctx.texture((1, 1), 4, bytes([128, 128, 255, 255]))
        self._flat_height = ctx.texture((1, 1), 1, np.zeros(1, "f4").tobytes(), dtype="f4")
        self._line_vbo = ctx.buffer(reserve=6 * 4 * 2 * 1024, dynamic=True)
        self._line_vao = ctx.vertex_array(
            self._lines, [(self._line_vbo, "3f 3f", "in_position", "in_colour")]
        )

    def _lit(
        self, options: RenderOptions, textured: bool = False, ground: bool = False
    ) -> moderngl.Program:
        """The body shader variant for these options, for bodies with or without their own
        base-colour image, or for the ground (compile-time switches: no cost when off)."""
        defines: dict[str, object] = {
            "PARALLAX": int(options.parallax),
            "VIEW": int(options.view),
            "SHADOW_TAPS": self.quality.shadow_taps,
            "SURFACE_DETAIL": int(self.quality.surface_detail),
            "TEXTURED": int(textured),
            "GROUND": int(ground),
        }
        return program(
            self.gl.cache, self.gl.ctx, "render/lit.vert", "render/lit.frag", defines=defines
        )

    @property
    def aspect(self) -> float:
        return self.size[0] / self.size[1]

    # -- frame ---------------------------------------------------------------------------------
    def render(
        self, description: FrameDescription, target: moderngl.Framebuffer | None = None
    ) -> moderngl.Framebuffer:
        """Draw one frame into `target` (an output-sized framebuffer, such as a window's) or, by
        default, into `self.output` (and `self.output_texture`); returns where it went."""
        ctx = self.gl.ctx
        target = target or self.output
        camera, light, options = description.camera, description.light, description.options
        view_proj = camera.view_proj(self.aspect)
        light_dir = np.asarray(light.direction, float)
        light_dir /= np.linalg.norm(light_dir)
        light_view_proj = self._light_matrix(camera.target, light_dir)
        frame = {
            "u_view_proj": view_proj,
            "u_light_view_proj": light_view_proj,
            "u_camera_pos": tuple(camera.eye),
            "u_light_dir": tuple(light_dir),
            "u_light_colour": tuple(np.asarray(light.colour) * light.intensity),
            "u_ambient": light.ambient,
        }
        items = list(description.items)
        ground = None
        if description.ground_y is not None:
            model = np.eye(4)
            model[1, 3] = description.ground_y
            ground = DrawItem(self._ground, model, GROUND)
        env = environment(self.gl, tuple(light_dir))
        # Shadow pass (the ground only receives shadows: nothing lies under it).
        self.shadow.use()
        ctx.viewport = (0, 0, *self.shadow_texture.size)
        self.shadow.clear(depth=1.0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        ctx.depth_func = "<"
        if options.shadows:
            _uniforms(self._depth, frame)
            shadow_texel = 2.0 * LIGHT_HALF_EXTENT / self.shadow_texture.size[0]  # m
            for item in items:
                _matrix(self._depth, "u_model", item.model)
                _level(item, shadow_texel).vao(self._depth).render(moderngl.TRIANGLES)
        # Bodies.
        self.msaa.use()
        ctx.viewport = (0, 0, *self.shade_size)
        self.msaa.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
        ctx.enable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.cull_face = "back"
        ctx.wireframe = options.wireframe
        self.shadow_texture.use(2)
        env.radiance.use(3)
        env.irradiance.use(4)
        pixel_at_metre = 2.0 * np.tan(np.radians(camera.fov_deg) / 2) / self.shade_size[1]
        plain = [item for item in items if item.texture is None]
        textured = [item for item in items if item.texture is not None]
        for group, prog in (
            (plain, self._lit(options)),
            (textured, self._lit(options, textured=True)),
            ([ground] if ground is not None else [], self._lit(options, ground=True)),
        ):  # the ground last: what bodies cover of it fails the depth test before shading
            if not group:
                continue
            _uniforms(prog, frame)
            for name, value in (
                ("u_shadow_map", 2),
                ("u_normal_map", 0),
                ("u_height_map", 1),
                ("u_radiance", 3),
                ("u_irradiance", 4),
                ("u_levels", LEVELS),
                ("u_exposure", EXPOSURE),
                ("u_base_texture", 5),
                ("u_legend_depth", options.legend_depth),
            ):
                _set(prog, name, value)
            for item in group:
                self._draw_lit(prog, item)
                distance = max(
                    float(np.linalg.norm(item.model[:3, 3] - camera.eye)) - item.mesh.radius,
                    NEAR,
                )
                _level(item, pixel_at_metre * distance).vao(prog).render(moderngl.TRIANGLES)
        ctx.wireframe = False
        # Sky: last, at the far plane, so that only the pixels no body covers run its shader.
        ctx.disable(moderngl.CULL_FACE)
        ctx.depth_func = "<="
        self.msaa.depth_mask = False  # (moderngl's Context has no depth_mask: a framebuffer's)
        _matrix(self._sky, "u_inverse_view_proj", np.linalg.inv(view_proj))
        _set(self._sky, "u_viewport", self.shade_size)
        _set(self._sky, "u_exposure", EXPOSURE)
        _set(self._sky, "u_ambient", light.ambient)
        _set(self._sky, "u_levels", LEVELS)
        _set(self._sky, "u_radiance", 3)
        env.radiance.use(3)
        self._empty_sky.render(moderngl.TRIANGLES, vertices=3)
        self.msaa.depth_mask = True
        ctx.depth_func = "<"
        if options.contacts and len(description.lines):
            self._draw_lines(description.lines, frame)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        if self.shade_size == self.size:
            ctx.copy_framebuffer(target, self.msaa)  # the MSAA resolve
        else:
            if self._msaa_colour is not self._resolved:
                ctx.copy_framebuffer(self._resolved_fbo, self.msaa)  # the MSAA resolve
            target.use()
            ctx.viewport = (0, 0, *self.size)
            self._resolved.use(0)
            _set(self._upscale, "u_frame", 0)
            _set(self._upscale, "u_viewport", self.size)
            self._empty_upscale.render(moderngl.TRIANGLES, vertices=3)
        target.use()
        ctx.viewport = (0, 0, *self.size)
        if options.address_map and description.inset is not None:
            self._draw_inset(description.inset)
        if options.view in (1, 2):
            self._draw_legend(options.view, options.legend_depth)
        return target

    def _draw_lit(self, prog: moderngl.Program, item: DrawItem) -> None:
        """Set the body shader's per-item uniforms and maps."""
        texture, appearance, maps, model = item.texture, item.look, item.maps, item.model
        if texture is not None:
            texture.use(5)
        _set(prog, "u_base_colour", appearance.base_colour)
        _set(prog, "u_metalness", appearance.metalness)
        _set(prog, "u_roughness", appearance.roughness)
        _set(prog, "u_surface", surface_code(appearance))
        _matrix(prog, "u_model", model)
        normal_matrix = np.linalg.inv(model[:3, :3]).T
        _matrix(prog, "u_normal_matrix", normal_matrix)
        if maps is not None:
            maps.normal.use(0)
            maps.height.use(1)
            w, h = maps.size
            _set(
                prog,
                "u_uv_per_metre",
                (1.0 / (maps.texel_metres[0] * w), 1.0 / (maps.texel_metres[1] * h)),
            )
            _set(prog, "u_max_depth", maps.max_dent_depth)
        else:
            self._flat_normal.use(0)
            self._flat_height.use(1)
            _set(prog, "u_max_depth", 0.0)

    def _light_matrix(self, centre: np.ndarray, direction: np.ndarray) -> np.ndarray:
        eye = centre - direction * 6.0
        up = (0.0, 0.0, 1.0) if abs(direction[1]) > 0.99 else (0.0, 1.0, 0.0)
        half = LIGHT_HALF_EXTENT
        return orthographic(half, half, 0.1, 14.0) @ look_at(eye, centre, up)

    def _draw_lines(self, lines: np.ndarray, frame: dict) -> None:
        data = np.ascontiguousarray(lines, "f4").ravel()[: self._line_vbo.size // 4]
        data = data[: len(data) // 12 * 12]  # whole segments
        self._line_vbo.write(data.tobytes())
        _uniforms(self._lines, frame)
        self.gl.ctx.disable(moderngl.DEPTH_TEST)
        self._line_vao.render(moderngl.LINES, vertices=len(data) // 6)

    def _draw_inset(self, inset: Inset) -> None:
        side = min(256, self.size[1] // 3)
        rect = (self.size[0] - side - 8, 8, side, side)
        inset.texture.use(0)
        _set(self._overlay, "u_texture", 0)
        _set(self._overlay, "u_rect", rect)
        _set(self._overlay, "u_extent", inset.extent)
        _set(self._overlay, "u_viewport", self.size)
        self._empty_rect.render(moderngl.TRIANGLE_STRIP, vertices=4)

    def _draw_legend(self, view: int, full_scale: float) -> None:
        key = (view, float(full_scale))
        if key not in self._legends:
            self._legends[key] = legend_texture(self.gl.ctx, view, full_scale)
        texture = self._legends[key]
        ctx = self.gl.ctx
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        texture.use(0)
        _set(self._image, "u_texture", 0)
        _set(self._image, "u_rect", (8, 8, *texture.size))
        _set(self._image, "u_viewport", self.size)
        self._empty_image.render(moderngl.TRIANGLE_STRIP, vertices=4)
        ctx.disable(moderngl.BLEND)

    def read_rgb(self) -> np.ndarray:
        """The last frame as uint8 [rows top-down, cols, 3] (screenshots and tests only)."""
        return self.gl.read_framebuffer(self.output)[::-1]

    def release(self) -> None:
        release(
            self._line_vao,
            self._line_vbo,
            self._empty_sky,
            self._empty_rect,
            self._empty_upscale,
            self._empty_image,
            *self._legends.values(),
            self._resolved_fbo,
            self._resolved,
            self.msaa,
            self.output,
            self.shadow,
            self._msaa_colour,  # the resolved texture itself without MSAA (released once)
            self._msaa_depth,
            self.output_texture,
            self.shadow_texture,
            self._flat_normal,
            self._flat_height,
        )
        self._ground.release()


def _level(item: DrawItem, metres_per_pixel: float) -> GpuMesh:
    """The coarsest mesh of `item` whose chord error stays under LEVEL_PIXELS pixels of
    `metres_per_pixel` (the pass's pixel footprint at the body)."""
    mesh = item.mesh
    for level in item.coarser:  # finest first
        if level.error > LEVEL_PIXELS * metres_per_pixel:
            break
        mesh = level.mesh
    return mesh


def _matrix(prog: moderngl.Program, name: str, m: np.ndarray) -> None:
    """A 4x4 or 3x3 matrix (column-vector convention) into a mat4 or mat3 uniform, if used."""
    _set(prog, name, np.asarray(m, dtype="f4").T.tobytes())


def _uniforms(prog: moderngl.Program, values: dict) -> None:
    for name, value in values.items():
        if name not in prog:
            continue
        if isinstance(value, np.ndarray) and value.shape == (4, 4):
            _matrix(prog, name, value)
        else:
            prog[name] = value
