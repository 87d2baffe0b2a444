"""The scene renderer: shadow pass, sky, normal-mapped bodies, debug views, MSAA resolve."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import moderngl
import numpy as np

from dentdemo.carve.surface import GpuMesh
from dentdemo.gl.context import GLContext, release
from dentdemo.gl.passes import ALPHA_BLEND, Pass, PassState
from dentdemo.gl.shaders import program
from dentdemo.mesh import primitives
from dentdemo.render.camera import NEAR, look_at, orthographic
from dentdemo.render.environment import LEVELS, Environment, environment
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

#: The sun's depth map: nearest depth wins, both faces (a plate's top casts too).
SHADOW = PassState(depth_test=True)
#: Bodies and the ground: depth-tested, back faces dropped.
BODIES = PassState(depth_test=True, cull="back")
#: The sky at the far plane, behind what is drawn ("<=" passes only where the depth is still
#: the cleared 1.0), leaving the depth as it is.
SKY = PassState(depth_test=True, depth_func="<=", depth_write=False)
#: Debug lines over everything, the stretch to the output and the inset: no test, no blending.
OVERLAY = PassState()
#: Legends over the frame, by their alpha.
LEGEND = PassState(blend=ALPHA_BLEND)
#: What the body pass samples, units 0 ... in this order (see _lit_textures).
LIT_SAMPLERS = (
    "u_normal_map",
    "u_height_map",
    "u_shadow_map",
    "u_radiance",
    "u_irradiance",
    "u_base_texture",
)


@dataclass(frozen=True)
class _Frame:
    """What the passes of one frame share."""

    description: FrameDescription
    #: Clip from world, the camera's.
    view_proj: np.ndarray
    #: Per-frame uniforms of frame.glsl (matrices as bytes).
    uniforms: dict[str, object]
    env: Environment
    items: list[DrawItem]
    #: The checkered ground as an item, or None.
    ground: DrawItem | None


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
        cache = gl.cache
        upscale = program(cache, ctx, "util/fullscreen.vert", "render/upscale.frag")
        self._upscale = Pass("upscale", upscale, OVERLAY, ("u_frame",))
        self._empty_upscale = ctx.vertex_array(upscale, [])
        self.shadow_texture = ctx.depth_texture((shadow_size, shadow_size))
        self.shadow_texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.shadow_texture.compare_func = "<="  # hardware comparison: bilinear PCF per tap
        self.shadow = ctx.framebuffer(depth_attachment=self.shadow_texture)
        depth = program(cache, ctx, "render/shadow.vert", "render/shadow.frag")
        self._shadow = Pass("shadow", depth, SHADOW)
        sky = program(
            cache, ctx, "util/fullscreen.vert", "render/sky.frag", defines={"AT_FAR_PLANE": 1}
        )
        self._sky = Pass("sky", sky, SKY, ("u_radiance",))
        self._empty_sky = ctx.vertex_array(sky, [])
        lines = program(cache, ctx, "render/lines.vert", "render/lines.frag")
        self._lines = Pass("lines", lines, OVERLAY)
        overlay = program(cache, ctx, "util/rect.vert", "render/overlay.frag")
        self._overlay = Pass("inset", overlay, OVERLAY, ("u_texture",))
        self._empty_rect = ctx.vertex_array(overlay, [])
        image = program(cache, ctx, "util/rect.vert", "render/image.frag")
        self._legend = Pass("legend", image, LEGEND, ("u_texture",))
        self._empty_image = ctx.vertex_array(image, [])
        self._legends: dict[tuple[int, float], moderngl.Texture] = {}
        self._ground = GpuMesh(gl, primitives.plate(GROUND_SIDE, subdivisions=1))
        self._flat_normal = ctx.texture((1, 1), 4, bytes([128, 128, 255, 255]))
        self._flat_height = ctx.texture((1, 1), 1, np.zeros(1, "f4").tobytes(), dtype="f4")
        self._line_vbo = ctx.buffer(reserve=6 * 4 * 2 * 1024, dynamic=True)
        self._line_vao = ctx.vertex_array(
            lines, [(self._line_vbo, "3f 3f", "in_position", "in_colour")]
        )
        #: The body passes' uniforms that never change.
        self._lit_constants = {"u_levels": LEVELS, "u_exposure": EXPOSURE}

    def _lit_pass(
        self, options: RenderOptions, textured: bool = False, ground: bool = False
    ) -> Pass:
        """The body pass for these options, for bodies with or without their own base-colour
        image, or for the ground: a shader variant each (compile-time switches: no cost when
        off), under BODIES state (filled, or edges only in the wireframe view)."""
        defines: dict[str, object] = {
            "PARALLAX": int(options.parallax),
            "VIEW": int(options.view),
            "SHADOW_TAPS": self.quality.shadow_taps,
            "SURFACE_DETAIL": int(self.quality.surface_detail),
            "TEXTURED": int(textured),
            "GROUND": int(ground),
        }
        lit = program(
            self.gl.cache, self.gl.ctx, "render/lit.vert", "render/lit.frag", defines=defines
        )
        return Pass("bodies", lit, replace(BODIES, wireframe=options.wireframe), LIT_SAMPLERS)

    @property
    def aspect(self) -> float:
        return self.size[0] / self.size[1]

    # -- frame ---------------------------------------------------------------------------------
    def render(
        self, description: FrameDescription, target: moderngl.Framebuffer | None = None
    ) -> moderngl.Framebuffer:
        """Draw one frame into `target` (an output-sized framebuffer, such as a window's) or, by
        default, into `self.output` (and `self.output_texture`); returns where it went. The frame
        is a list of passes (each a `gl.passes.Pass` with its declared state): shadow map, bodies,
        sky, debug lines, resolve or stretch to the output, overlays."""
        target = target or self.output
        frame = self._frame(description)
        self._shadow_pass(frame)
        self._body_passes(frame)
        self._sky_pass(frame)
        if description.options.contacts and len(description.lines):
            self._lines_pass(frame, description.lines)
        self._to_output(target)
        options = description.options
        if options.address_map and description.inset is not None:
            self._inset_pass(target, description.inset)
        if options.view in (1, 2):
            self._legend_pass(target, options.view, options.legend_depth)
        return target

    def _frame(self, description: FrameDescription) -> _Frame:
        """What every pass of this frame shares: matrices, light, the environment, the items."""
        camera, light = description.camera, description.light
        view_proj = camera.view_proj(self.aspect)
        light_dir = np.asarray(light.direction, float)
        light_dir /= np.linalg.norm(light_dir)
        light_view_proj = self._light_matrix(camera.target, light_dir)
        uniforms = {
            "u_view_proj": _bytes(view_proj),
            "u_light_view_proj": _bytes(light_view_proj),
            "u_camera_pos": tuple(camera.eye),
            "u_light_dir": tuple(light_dir),
            "u_light_colour": tuple(np.asarray(light.colour) * light.intensity),
            "u_ambient": light.ambient,
        }
        ground = None
        if description.ground_y is not None:
            model = np.eye(4)
            model[1, 3] = description.ground_y
            ground = DrawItem(self._ground, model, GROUND)
        return _Frame(
            description,
            view_proj,
            uniforms,
            environment(self.gl, tuple(light_dir)),
            list(description.items),
            ground,
        )

    def _shadow_pass(self, frame: _Frame) -> None:
        """Depth from the sun (the ground only receives shadows: nothing lies under it)."""
        self.shadow.clear(depth=1.0)
        if not frame.description.options.shadows:
            return
        side = self.shadow_texture.size[0]
        shadow_texel = 2.0 * LIGHT_HALF_EXTENT / side  # m
        with self._shadow.batch(self.gl.ctx, self.shadow) as draw:
            for item in frame.items:
                uniforms = {**frame.uniforms, "u_model": _bytes(item.model)}
                draw((0, 0, side, side), _level(item, shadow_texel).drawer(None, ""), (), uniforms)

    def _body_passes(self, frame: _Frame) -> None:
        """The bodies without and with their own image, then the ground: what bodies cover of it
        fails the depth test before shading."""
        options, camera = frame.description.options, frame.description.camera
        self.msaa.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
        pixel_at_metre = 2.0 * np.tan(np.radians(camera.fov_deg) / 2) / self.shade_size[1]
        plain = [item for item in frame.items if item.texture is None]
        textured = [item for item in frame.items if item.texture is not None]
        per_frame = {
            **frame.uniforms,
            **self._lit_constants,
            "u_legend_depth": options.legend_depth,
        }
        ground = [frame.ground] if frame.ground is not None else []
        for group, variant in (
            (plain, self._lit_pass(options)),
            (textured, self._lit_pass(options, textured=True)),
            (ground, self._lit_pass(options, ground=True)),
        ):
            if not group:
                continue
            with variant.batch(self.gl.ctx, self.msaa) as draw:
                for item in group:
                    distance = max(
                        float(np.linalg.norm(item.model[:3, 3] - camera.eye)) - item.mesh.radius,
                        NEAR,
                    )
                    mesh = _level(item, pixel_at_metre * distance)
                    draw(
                        (0, 0, *self.shade_size),
                        mesh.drawer(None, ""),
                        self._lit_textures(item, frame),
                        {**per_frame, **self._lit_uniforms(item)},
                    )

    def _sky_pass(self, frame: _Frame) -> None:
        """Last, at the far plane, so that only the pixels no body covers run its shader."""
        light = frame.description.light
        uniforms = {
            "u_inverse_view_proj": _bytes(np.linalg.inv(frame.view_proj)),
            "u_viewport": self.shade_size,
            "u_exposure": EXPOSURE,
            "u_ambient": light.ambient,
            "u_levels": LEVELS,
        }
        self._sky.run(
            self.gl.ctx,
            self.msaa,
            (0, 0, *self.shade_size),
            _fullscreen(self._empty_sky),
            (frame.env.radiance,),
            uniforms,
        )

    def _lines_pass(self, frame: _Frame, lines: np.ndarray) -> None:
        data = np.ascontiguousarray(lines, "f4").ravel()[: self._line_vbo.size // 4]
        data = data[: len(data) // 12 * 12]  # whole segments
        self._line_vbo.write(data.tobytes())

        def draw(_: moderngl.Program) -> None:
            self._line_vao.render(moderngl.LINES, vertices=len(data) // 6)

        self._lines.run(self.gl.ctx, self.msaa, (0, 0, *self.shade_size), draw, (), frame.uniforms)

    def _to_output(self, target: moderngl.Framebuffer) -> None:
        """The MSAA resolve into `target`, or (when the preset shades fewer pixels) the resolve
        into the shaded-size texture and its bilinear stretch onto `target`."""
        ctx = self.gl.ctx
        if self.shade_size == self.size:
            ctx.copy_framebuffer(target, self.msaa)
            return
        if self._msaa_colour is not self._resolved:
            ctx.copy_framebuffer(self._resolved_fbo, self.msaa)
        self._upscale.run(
            ctx,
            target,
            (0, 0, *self.size),
            _fullscreen(self._empty_upscale),
            (self._resolved,),
            {"u_viewport": self.size},
        )

    def _inset_pass(self, target: moderngl.Framebuffer, inset: Inset) -> None:
        side = min(256, self.size[1] // 3)
        uniforms = {
            "u_rect": (self.size[0] - side - 8, 8, side, side),
            "u_extent": inset.extent,
            "u_viewport": self.size,
        }
        self._overlay.run(
            self.gl.ctx,
            target,
            (0, 0, *self.size),
            _strip(self._empty_rect),
            (inset.texture,),
            uniforms,
        )

    def _legend_pass(self, target: moderngl.Framebuffer, view: int, full_scale: float) -> None:
        key = (view, float(full_scale))
        if key not in self._legends:
            self._legends[key] = legend_texture(self.gl.ctx, view, full_scale)
        texture = self._legends[key]
        self._legend.run(
            self.gl.ctx,
            target,
            (0, 0, *self.size),
            _strip(self._empty_image),
            (texture,),
            {"u_rect": (8, 8, *texture.size), "u_viewport": self.size},
        )

    def _lit_textures(self, item: DrawItem, frame: _Frame) -> tuple[moderngl.Texture, ...]:
        """The body pass's maps for `item`, in the order of LIT_SAMPLERS."""
        normal, height = (
            (item.maps.normal, item.maps.height)
            if item.maps is not None
            else (self._flat_normal, self._flat_height)
        )
        base = item.texture if item.texture is not None else self._flat_normal  # (unread)
        env = frame.env
        return (normal, height, self.shadow_texture, env.radiance, env.irradiance, base)

    def _lit_uniforms(self, item: DrawItem) -> dict[str, object]:
        """The body pass's per-item uniforms: look, pose, and the maps' scale and depth."""
        appearance, maps, model = item.look, item.maps, item.model
        uniforms: dict[str, object] = {
            "u_base_colour": appearance.base_colour,
            "u_metalness": appearance.metalness,
            "u_roughness": appearance.roughness,
            "u_surface": surface_code(appearance),
            "u_model": _bytes(model),
            "u_normal_matrix": _bytes(np.linalg.inv(model[:3, :3]).T),
            "u_max_depth": 0.0,
        }
        if maps is not None:
            w, h = maps.size
            uniforms["u_uv_per_metre"] = (
                1.0 / (maps.texel_metres[0] * w),
                1.0 / (maps.texel_metres[1] * h),
            )
            uniforms["u_max_depth"] = maps.max_dent_depth
        return uniforms

    def _light_matrix(self, centre: np.ndarray, direction: np.ndarray) -> np.ndarray:
        eye = centre - direction * 6.0
        up = (0.0, 0.0, 1.0) if abs(direction[1]) > 0.99 else (0.0, 1.0, 0.0)
        half = LIGHT_HALF_EXTENT
        return orthographic(half, half, 0.1, 14.0) @ look_at(eye, centre, up)

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


def _bytes(m: np.ndarray) -> bytes:
    """A 4x4 or 3x3 matrix (column-vector convention) as a mat4 or mat3 uniform's bytes."""
    return np.asarray(m, dtype="f4").T.tobytes()


def _fullscreen(vao: moderngl.VertexArray) -> Callable[[moderngl.Program], None]:
    """Draw one triangle that covers the viewport (util/fullscreen.vert)."""
    return lambda _: vao.render(moderngl.TRIANGLES, vertices=3)


def _strip(vao: moderngl.VertexArray) -> Callable[[moderngl.Program], None]:
    """Draw one rectangle as a strip of four vertices (util/rect.vert)."""
    return lambda _: vao.render(moderngl.TRIANGLE_STRIP, vertices=4)
