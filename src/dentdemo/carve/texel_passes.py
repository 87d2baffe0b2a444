"""Passes 4 and 5 draw a body's triangles in texture space (carve/texel.geom); this module builds
those passes and holds pass 5, the normal rebuild, which map creation uses too."""

from __future__ import annotations

from typing import TYPE_CHECKING

import moderngl
import numpy as np
from numpy.typing import NDArray

from dentdemo.carve.camera import CollisionCamera
from dentdemo.carve.constants import shader_defines
from dentdemo.carve.jobs import RECT_BINDING, RECT_BLOCK, RECT_ENTRIES, job_entries, job_table
from dentdemo.carve.linear import column_scale, inverse3
from dentdemo.carve.params import (
    Camera,
    Clip,
    Draw,
    Pose,
    Quad,
    Swept,
    TexelDraw,
    TexelUniforms,
    check_program,
)
from dentdemo.gl.context import GLContext
from dentdemo.gl.passes import MIN_BLEND, Pass, PassState
from dentdemo.gl.shaders import program

if TYPE_CHECKING:
    from dentdemo.gpu.maps import SurfaceMaps
    from dentdemo.gpu.mesh import GpuMesh
    from dentdemo.mesh.mesh import Mesh

#: Clip distances clip.glsl writes (camera rectangle: 4, depth slab: 2).
CLIP_DISTANCES = 6
_GATHER = PassState(blend=MIN_BLEND, clip_distances=CLIP_DISTANCES)
_NORMALS = PassState(clip_distances=CLIP_DISTANCES)


#: How a texture-space draw covers its texels (the second item of a pass's key): the chart
#: texels of the footprint's triangles, the gutter texels around their chart borders
#: (texel.geom), or a built-in sphere's chart texels in rectangles (util/rect.vert: the facet
#: under each texel worked out from the sphere's atlas, cube_grid.glsl).
CHART, GUTTER, RECT = TexelDraw.CHART, TexelDraw.GUTTER, TexelDraw.RECT


def texture_space_passes(gl: GLContext) -> dict[tuple, Pass]:
    """Pass 4 by ("gather", draw, swept, oblique, convex) and pass 5 by ("normals", draw, False),
    `draw` one of CHART, GUTTER (GUTTER 1) and RECT (RECT 1); the gather also for a swept solid's
    own surface (SWEPT 1), with or without the exit along each normal (EXIT), and for a target
    that hides none of its own surface, without the address map (CONVEX; the normal rebuild
    reads only the map, so it has none of these variants). RECT only for what a built-in sphere
    uses: swept, oblique, convex. Cached per context."""
    key = "carve:texture-space-passes"
    if key in gl.cache:
        return gl.cache[key]
    passes: dict[tuple, Pass] = {}
    gather = ("u_address", "u_tool_depth", "u_mask")
    # (name, state, samplers, variants: (swept, oblique, convex)): a swept solid's normals always
    # vary and it is convex; the normal rebuild's only variant is (swept False,).
    gathers = [(False, oblique, convex) for oblique in (False, True) for convex in (False, True)]
    kinds: tuple[tuple[str, PassState, tuple[str, ...], list[tuple[bool, ...]]], ...] = (
        ("gather", _GATHER, gather, [*gathers, (True, True, True)]),
        ("normals", _NORMALS, ("u_height", "u_mask"), [(False,)]),
    )
    stages = {
        CHART: ("carve/texel.vert", None),
        GUTTER: ("carve/texel.vert", "carve/texel.geom"),
        RECT: ("util/rect.vert", None),
    }
    for draw, (vertex, geometry) in stages.items():
        for name, state, samplers, variants in kinds:
            for variant in variants:
                if draw == RECT and variant not in ((True, True, True), (False,)):
                    continue
                names = ("SWEPT", "EXIT", "CONVEX")[: len(variant)]
                defines: dict[str, object] = {
                    key: int(value) for key, value in zip(names, variant, strict=True)
                }
                defines["RING"] = int(name == "normals")  # pass 5 clips to the ring's slab
                if draw == RECT:  # under the same state as the triangles' draws; instanced
                    defines.update(
                        RECT=1,
                        RECT_TABLE=1,
                        RECT_ENTRIES=RECT_ENTRIES,
                        CLIP_DISTANCES=CLIP_DISTANCES,
                        **sphere_atlas_defines(),
                    )
                prog = program(
                    gl.cache,
                    gl.ctx,
                    vertex,
                    f"carve/{name}.frag",
                    geometry,
                    defines=shader_defines(
                        GUTTER=int(draw == GUTTER), JOB_ENTRIES=job_entries(gl.ctx), **defines
                    ),
                )
                which = (name, draw, *variant)
                check_program(prog, TexelUniforms, samplers, f"carve pass {which}")
                rects = prog.get(RECT_BLOCK, None)
                if isinstance(rects, moderngl.UniformBlock):
                    rects.binding = RECT_BINDING
                passes[which] = Pass(name, prog, state, samplers, VARIANT_KEYS)
    gl.cache[key] = passes
    return passes


def sphere_atlas_defines() -> dict[str, str]:
    """The built-in sphere's atlas (mesh/cube.py's faces, mesh/primitives.py's gutter) as
    defines for sphere_uv.glsl and cube_grid.glsl; capsule_uv.glsl shares the gutter."""
    from dentdemo.mesh.cube import CUBE_FACES
    from dentdemo.mesh.primitives import GUTTER as ATLAS_GUTTER

    def table(k: int) -> str:
        return (
            "vec3[6](" + ", ".join(f"vec3{tuple(float(x) for x in f[k])}" for f in CUBE_FACES) + ")"
        )

    return {
        "CUBE_FACE_N": table(0),
        "CUBE_FACE_A": table(1),
        "CUBE_FACE_B": table(2),
        "ATLAS_GUTTER": repr(float(ATLAS_GUTTER)),
    }


def rebuild_normals(gl: GLContext, gpu_mesh: GpuMesh, maps: SurfaceMaps) -> None:
    """Pass 5 over every texel of the map, unclipped (map creation, import): every triangle's
    chart texels, then the gutter texels around the chart-border triangles. A hit's pass 5 is
    `Carver._normal_passes`, over its footprint."""
    passes = texture_space_passes(gl)
    entry = TexelUniforms(model_uniforms(np.eye(4)), Clip(u_clip=False, u_map_size=maps.size))
    table = job_table(gl.cache, gl.ctx)
    table.write([entry.values()])
    uniforms = Draw(u_job=table.use(0)).values()
    border = np.nonzero(gpu_mesh.mesh.chart_border())[0]
    for kind, triangles in ((CHART, None), (GUTTER, border)):
        if triangles is not None and len(triangles) == 0:
            continue
        passes["normals", kind, False].run(
            gl.ctx,
            maps.normal_fbo,
            (0, 0, *maps.size),
            gpu_mesh.drawer(triangles, f"texels{kind}"),
            (maps.height, maps.mask),
            uniforms,
        )


def camera_uniforms(cam: CollisionCamera) -> Camera:
    x, y, z = cam.eye.tolist()
    return Camera(
        u_eye=(x, y, z),
        u_right=_vec3(cam.right),
        u_up=_vec3(cam.up),
        u_forward=_vec3(cam.forward),
        u_half_extent=cam.half_extent,
        u_depth_range=cam.depth_range,
        u_resolution=cam.resolution,
    )


def _vec3(v: NDArray[np.float64]) -> tuple[float, float, float]:
    x, y, z = v.tolist()
    return x, y, z


def clip_uniforms(cam: CollisionCamera, maps: SurfaceMaps) -> Clip:
    """Keep the texels whose surface projects inside the camera and lies in its slab (view
    depth; pass 5: in its slab grown by the ring, `ring_slab`)."""
    return Clip(
        u_clip=True,
        u_map_size=maps.size,
        u_clip_half=cam.half_extent,
        u_slab=cam.slab,
        u_ring_slab=cam.ring_slab,
    )


#: Keys of the carve's uniform dicts that pick a pass's variant (SWEPT: a bool, QUAD: a `Quad`)
#: and name no uniform.
VARIANT_KEYS = frozenset({"u_swept", "u_quad"})


def swept_solid(
    mesh: Mesh, model: NDArray[np.float64], inverse: NDArray[np.float64] | None = None
) -> Swept | None:
    """A built-in sphere or capsule's own solid (world metres) for the passes that put points
    on its smooth surface; None for other meshes, which keep their facets. `inverse`: the
    inverse of the pose's linear part, where the caller has it."""
    bound = mesh.bound
    if bound is None or bound.segment is None or not bound.exact:
        return None
    m = np.asarray(model, dtype=np.float64)
    linear = m[:3, :3]
    ends = bound.segment @ linear.T + m[:3, 3]
    if inverse is None:
        inverse = inverse3(linear)
    grid = bound.quad == Quad.SPHERE and bound.grid > 0  # cube_grid.glsl: passes 4, 5 as rects
    capsule = None
    if bound.quad == Quad.CAPSULE:  # capsule_uv.glsl: local radius, half length, rows
        half = float(np.linalg.norm(bound.segment[1] - bound.segment[0])) / 2
        capsule = (bound.radius, half, float(bound.rings))
    return Swept(
        u_swept_a=_vec3(ends[0]),
        u_swept_b=_vec3(ends[1]),
        # The solid's radius scales with the pose's largest column (a rotation times a scale).
        u_swept_radius=bound.radius * column_scale(linear),
        u_swept_local=inverse.astype("f4").tobytes(order="F"),  # local from world, column-major
        u_cube_grid=bound.grid if grid else None,
        u_cube_radius=bound.radius if grid else None,
        u_capsule=capsule,
    )


def pose_uniforms(mesh: Mesh, model: NDArray[np.float64]) -> dict[str, object]:
    """The `Pose` and `swept_solid` uniforms of `mesh` posed at `model` (one inverse of the pose
    for both), with the selectors of the passes' variants: `u_swept` (SWEPT) and `u_quad`
    (QUAD: passes 2 and 3 draw a sphere or a capsule as one quad)."""
    m = np.asarray(model, dtype=np.float64)
    inverse = inverse3(m[:3, :3])
    swept = swept_solid(mesh, m, inverse)
    selectors: dict[str, object] = {"u_swept": swept is not None}
    if swept is not None:
        selectors["u_quad"] = quad_kind(mesh)
        selectors.update(swept.values())
    return {**model_uniforms(m, inverse).values(), **selectors}


def is_swept(mesh: Mesh) -> bool:
    """A built-in sphere or capsule: its own swept sphere is its surface (the SWEPT variants)."""
    bound = mesh.bound
    return bound is not None and bound.exact and bound.segment is not None


def quad_kind(mesh: Mesh) -> Quad:
    """How passes 2 and 3 may draw a built-in shape as one quad (its QUAD variant): 1 a sphere,
    2 a capsule, 0 not (`Bound.quad`)."""
    bound = mesh.bound
    return Quad(0 if bound is None else bound.quad)


def cube_grid(mesh: Mesh) -> int:
    """A built-in sphere's cells per cube-face edge, whose chart texels passes 4 and 5 may draw
    as rectangles (RECT), or 0."""
    bound = mesh.bound
    return bound.grid if bound is not None and bound.quad == 1 else 0


def model_uniforms(model: NDArray[np.float64], inverse: NDArray[np.float64] | None = None) -> Pose:
    """The pose (world from local) and its normal matrix, column-major; `inverse`: the inverse
    of its linear part, where the caller has it."""
    m = np.asarray(model, dtype=np.float64)
    if inverse is None:
        inverse = inverse3(m[:3, :3])
    return Pose(
        u_model=m.astype("f4").tobytes(order="F"),  # column-major
        # The normal matrix inverse.T, column-major: the inverse's rows.
        u_normal_matrix=inverse.astype("f4").tobytes(),
    )
