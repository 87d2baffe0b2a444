"""The scene renderer: shadow pass, sky, normal-mapped bodies, debug views, MSAA resolve."""

from __future__ import annotations

import weakref
from collections.abc import Callable
from dataclasses import dataclass, replace

import moderngl
import numpy as np

from dentdemo.gl.context import GLContext, release
from dentdemo.gl.passes import ALPHA_BLEND, Pass, PassState, Sampled
from dentdemo.gl.shaders import program
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.mesh import primitives
from dentdemo.render.camera import NEAR, look_at, orthographic
from dentdemo.render.displacement import displacement_path
from dentdemo.render.environment import LEVELS, Environment, environment
from dentdemo.render.frame import DrawItem, FrameDescription, Inset, RenderOptions
from dentdemo.render.legend import legend_texture
from dentdemo.render.looks import GROUND, surface_code
from dentdemo.render.quality import Quality, preset
from dentdemo.render.refine import cuts_for, refine
from dentdemo.render.seams import seam_twins

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
    "u_displacement_map",
)
#: How an item's surface is drawn (the shaders' DISPLACE): as the mesh is, moved vertex by vertex
#: on a finer mesh (render/refine.py), or cut and moved by the tessellation stages.
FLAT, MESH, TESSELLATE = 0, 1, 2
#: The tessellation stages of a displaced pass.
TESSELLATION = ("render/displace.tesc", "render/displace.tese")
#: Most segments per edge on a software rasteriser: llvmpipe (Mesa 22.3) reports 64 but drops
#: triangles above about 16 (a cut ball's side view loses 0.4 % of its pixels at 20, 1.1 % at
#: 32; a ball 14 mm from the eye came out as a sheet over the whole frame at 24).
SOFTWARE_MAX_LEVEL = 16


@dataclass(frozen=True)
class _Twins:
    """A mesh's seam twins on the GPU (4 floats a vertex) and its displaced vertex arrays."""

    buffer: moderngl.Buffer
    #: By program (its GL name).
    vaos: dict[int, moderngl.VertexArray]


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
    #: Per item: the metres a pixel spans at its nearest point, and how it is drawn (FLAT,
    #: MESH or TESSELLATE; the shadow pass draws it the same way).
    pixel_metres: list[float]
    modes: list[int]


class Renderer:
    """Draws a FrameDescription into an MSAA framebuffer and resolves it into `output` (sRGB
    bytes). It knows nothing of the simulation: what to draw comes in the description."""

    def __init__(
        self,
        gl: GLContext,
        size: tuple[int, int],
        quality: Quality | None = None,
        displacement: str | None = None,
    ) -> None:
        """`displacement`: "tessellation" or "mesh" (render/displacement.py); None: chosen by the
        context and DENTDEMO_DISPLACEMENT."""
        self.gl = gl
        ctx = gl.ctx
        self.quality = quality or preset(None, gl.software)
        #: How deep dents move the surface: "tessellation" or "mesh" (a preset that cuts nothing,
        #: max_segments 1, moves the drawn mesh's vertices: the tessellation stages would only
        #: add their cost).
        self.displacement = displacement_path(ctx, displacement)
        if self.quality.max_segments == 1:
            self.displacement = "mesh"
        self.size = size
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
        #: The shadow pass by how items are drawn (FLAT, MESH, TESSELLATE), made when needed.
        self._shadows: dict[int, Pass] = {}
        #: The height maps as displacement reads them: bilinear, clamped at the edges.
        self._linear = ctx.sampler(
            filter=(moderngl.LINEAR, moderngl.LINEAR), repeat_x=False, repeat_y=False
        )
        #: Finer render meshes of the MESH path, by source mesh and cuts per edge.
        self._refined: weakref.WeakKeyDictionary[GpuMesh, dict[int, GpuMesh]] = (
            weakref.WeakKeyDictionary()
        )
        self._edges: weakref.WeakKeyDictionary[GpuMesh, float] = weakref.WeakKeyDictionary()
        #: Per mesh drawn displaced: its seam twins (render/seams.py) in a vertex buffer, and
        #: vertex arrays with them, by program.
        self._twins: weakref.WeakKeyDictionary[GpuMesh, _Twins] = weakref.WeakKeyDictionary()
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
        self,
        options: RenderOptions,
        textured: bool = False,
        ground: bool = False,
        mode: int = FLAT,
    ) -> Pass:
        """The body pass for these options, for bodies with or without their own base-colour
        image, or for the ground, drawn FLAT, MESH or TESSELLATE: a shader variant each
        (compile-time switches: no cost when off), under BODIES state (filled, or edges only in
        the wireframe view)."""
        defines: dict[str, object] = {
            "DISPLACE": mode,
            "PARALLAX": int(options.parallax),
            "VIEW": int(options.view),
            "SHADOW_TAPS": self.quality.shadow_taps,
            "SURFACE_DETAIL": int(self.quality.surface_detail),
            "TEXTURED": int(textured),
            "GROUND": int(ground),
        }
        lit = program(
            self.gl.cache,
            self.gl.ctx,
            "render/lit.vert",
            "render/lit.frag",
            defines=defines,
            tessellation=TESSELLATION if mode == TESSELLATE else None,
        )
        return Pass("bodies", lit, replace(BODIES, wireframe=options.wireframe), LIT_SAMPLERS)

    def _shadow_pass_for(self, mode: int) -> Pass:
        """The shadow pass for items drawn FLAT, MESH or TESSELLATE."""
        if mode not in self._shadows:
            depth = program(
                self.gl.cache,
                self.gl.ctx,
                "render/shadow.vert",
                "render/shadow.frag",
                defines={"DISPLACE": mode, "SHADOW": 1},
                tessellation=TESSELLATION if mode == TESSELLATE else None,
            )
            self._shadows[mode] = Pass("shadow", depth, SHADOW, ("u_displacement_map",))
        return self._shadows[mode]

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
        items = list(description.items)
        rows = self.shade_size[1]
        pixel_metres = [
            camera.metres_per_pixel(
                max(float(np.linalg.norm(item.model[:3, 3] - camera.eye)) - item.mesh.radius, NEAR),
                rows,
            )
            for item in items
        ]
        options = description.options
        modes = [self._mode(item, options, m) for item, m in zip(items, pixel_metres, strict=True)]
        return _Frame(
            description,
            view_proj,
            uniforms,
            environment(self.gl, tuple(light_dir)),
            items,
            ground,
            pixel_metres,
            modes,
        )

    def _mode(self, item: DrawItem, options: RenderOptions, pixel_metres: float) -> int:
        """FLAT unless displacement is on and the item's maps can hold a dent (or bump) at least
        the preset's deep_pixels deep at its distance (the maps' bounds: the CPU does not know
        where the dents are); then MESH or TESSELLATE, the path this renderer uses."""
        maps = item.maps
        if not options.displace or maps is None:
            return FLAT
        reach = max(maps.max_dent_depth, maps.max_height)  # m
        if reach < self.quality.deep_pixels * pixel_metres:
            return FLAT
        return TESSELLATE if self.displacement == "tessellation" else MESH

    def _drawer(
        self, item: DrawItem, pixel_metres: float, mode: int
    ) -> Callable[[moderngl.Program], None]:
        """How to draw `item` with a pass's program: the coarsest mesh level whose chord error
        stays under LEVEL_PIXELS of `pixel_metres`, as triangles, cut finer (MESH) or as
        patches (TESSELLATE)."""
        mesh = _level(item, pixel_metres)
        if mode == FLAT:
            return mesh.drawer(None, "")
        if mode == MESH:
            scale = float(np.linalg.norm(item.model[:3, :3], ord=2))  # world m per local m
            q = self.quality
            cuts = cuts_for(
                self._edge(mesh) * scale, pixel_metres, q.segment_pixels, q.max_segments
            )
            mesh = self._cut(mesh, cuts)
        primitive = moderngl.PATCHES if mode == TESSELLATE else moderngl.TRIANGLES
        return lambda prog: self._displaced_vao(mesh, prog).render(primitive)

    def _displaced_vao(self, mesh: GpuMesh, prog: moderngl.Program) -> moderngl.VertexArray:
        """A vertex array of `mesh` for a displaced pass: the mesh's own attributes and its seam
        twins (made once per mesh and program)."""
        if mesh not in self._twins:
            buffer = self.gl.ctx.buffer(seam_twins(mesh.mesh).tobytes())
            self._twins[mesh] = _Twins(buffer, {})
        twins = self._twins[mesh]
        if prog.glo not in twins.vaos:
            used = [n for n in GpuMesh._NAMES if n in prog]
            layout = " ".join(
                f if n in used else f"{f[0]}x4"
                for f, n in zip(GpuMesh._LAYOUT.split(), GpuMesh._NAMES, strict=True)
            )
            content = [(mesh.vbo, layout, *used), (twins.buffer, "4f", "in_twin_uv")]
            twins.vaos[prog.glo] = self.gl.ctx.vertex_array(prog, content, mesh.ibo)
        return twins.vaos[prog.glo]

    def _edge(self, mesh: GpuMesh) -> float:
        """The 90th percentile of the mesh's edge lengths, local metres."""
        if mesh not in self._edges:
            a, b, c = mesh.mesh.triangle_corners()
            lengths = np.linalg.norm(np.concatenate([b - a, c - b, a - c]), axis=1)
            self._edges[mesh] = float(np.percentile(lengths, 90))
        return self._edges[mesh]

    def _cut(self, mesh: GpuMesh, cuts: int) -> GpuMesh:
        """`mesh` with each triangle cut into cuts^2 (made once, then kept)."""
        if cuts == 1:
            return mesh
        kept = self._refined.setdefault(mesh, {})
        if cuts not in kept:
            kept[cuts] = GpuMesh(self.gl, refine(mesh.mesh, cuts))
        return kept[cuts]

    def _tessellation(self, view_proj: object, pixels_per_metre: float) -> dict[str, object]:
        """The tessellation stages' uniforms for a pass seen through `view_proj`."""
        q = self.quality
        return {
            "u_tess_view_proj": view_proj,
            "u_pixels_per_metre": pixels_per_metre,
            "u_segment_pixels": q.segment_pixels,
            "u_max_level": float(
                min(q.max_segments, SOFTWARE_MAX_LEVEL) if self.gl.software else q.max_segments
            ),
            "u_deep_pixels": q.deep_pixels,
        }

    def _shadow_pass(self, frame: _Frame) -> None:
        """Depth from the sun (the ground only receives shadows: nothing lies under it). Items
        are drawn as in the body pass (FLAT, MESH or TESSELLATE), so the shadow moves with the
        surface; the tessellation counts pixels of the shadow map."""
        self.shadow.clear(depth=1.0)
        if not frame.description.options.shadows:
            return
        side = self.shadow_texture.size[0]
        shadow_texel = 2.0 * LIGHT_HALF_EXTENT / side  # m
        tessellation = self._tessellation(
            frame.uniforms["u_light_view_proj"], side / (2.0 * LIGHT_HALF_EXTENT)
        )
        for mode in (FLAT, MESH, TESSELLATE):
            group = [i for i, m in enumerate(frame.modes) if m == mode]
            if not group:
                continue
            with self._shadow_pass_for(mode).batch(self.gl.ctx, self.shadow) as draw:
                for i in group:
                    item = frame.items[i]
                    uniforms = {**frame.uniforms, **tessellation, "u_model": _bytes(item.model)}
                    draw(
                        (0, 0, side, side),
                        self._drawer(item, shadow_texel, mode),
                        (self._displacement_map(item),),
                        uniforms,
                    )

    def _body_passes(self, frame: _Frame) -> None:
        """The bodies without and with their own image, each drawn FLAT, MESH or TESSELLATE,
        then the ground: what bodies cover of it fails the depth test before shading."""
        description = frame.description
        options, camera = description.options, description.camera
        background = description.background
        if background is None:
            self.msaa.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
        else:
            self.msaa.clear(*background, 0.0, depth=1.0)
        per_frame = {
            **frame.uniforms,
            **self._lit_constants,
            **self._tessellation(
                frame.uniforms["u_view_proj"], camera.pixels_per_metre(self.shade_size[1])
            ),
            "u_legend_depth": options.legend_depth,
        }
        for textured in (False, True):
            for mode in (FLAT, MESH, TESSELLATE):
                group = [
                    i
                    for i, item in enumerate(frame.items)
                    if (item.texture is not None) == textured and frame.modes[i] == mode
                ]
                if not group:  # no variant: a GL 3.3 context cannot build the TESSELLATE one
                    continue
                variant = self._lit_pass(options, textured=textured, mode=mode)
                with variant.batch(self.gl.ctx, self.msaa) as draw:
                    for i in group:
                        item = frame.items[i]
                        draw(
                            (0, 0, *self.shade_size),
                            self._drawer(item, frame.pixel_metres[i], mode),
                            self._lit_textures(item, frame),
                            {**per_frame, **self._lit_uniforms(item)},
                        )
        if frame.ground is not None:
            ground = frame.ground
            self._lit_pass(options, ground=True).run(
                self.gl.ctx,
                self.msaa,
                (0, 0, *self.shade_size),
                ground.mesh.drawer(None, ""),
                self._lit_textures(ground, frame),
                {**per_frame, **self._lit_uniforms(ground)},
            )

    def _sky_pass(self, frame: _Frame) -> None:
        """Last, at the far plane, so that only the pixels no body covers run its shader; none
        on a plain background."""
        if frame.description.background is not None:
            return
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

    def _lit_textures(self, item: DrawItem, frame: _Frame) -> tuple[Sampled, ...]:
        """The body pass's maps for `item`, in the order of LIT_SAMPLERS."""
        normal, height = (
            (item.maps.normal, item.maps.height)
            if item.maps is not None
            else (self._flat_normal, self._flat_height)
        )
        base = item.texture if item.texture is not None else self._flat_normal  # (unread)
        env = frame.env
        displacement = self._displacement_map(item)
        return (
            normal,
            height,
            self.shadow_texture,
            env.radiance,
            env.irradiance,
            base,
            displacement,
        )

    def _displacement_map(self, item: DrawItem) -> tuple[moderngl.Texture, moderngl.Sampler]:
        """The item's height map through the bilinear sampler (a flat stand-in without maps)."""
        return (item.maps.height if item.maps is not None else self._flat_height, self._linear)

    def _lit_uniforms(self, item: DrawItem) -> dict[str, object]:
        """The body pass's per-item uniforms: look, pose, and the maps' scale and depth."""
        appearance, maps, model = item.look, item.maps, item.model
        uniforms: dict[str, object] = {
            "u_base_colour": appearance.base_colour,
            "u_metalness": appearance.metalness,
            "u_roughness": appearance.roughness,
            "u_surface": surface_code(appearance),
            "u_coat_thickness": appearance.coat_thickness,
            "u_coat_colour": appearance.coat_colour,
            "u_coat_metalness": appearance.coat_metalness,
            "u_coat_roughness": appearance.coat_roughness,
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
            self._linear,
        )
        self._ground.release()
        for twins in self._twins.values():
            release(*twins.vaos.values(), twins.buffer)
        for kept in self._refined.values():
            for mesh in kept.values():
                mesh.release()


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
