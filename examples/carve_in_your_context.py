"""Carve a dent into a mesh in your own moderngl context, and show it.

The host here is a tiny offscreen renderer: it owns the context, the framebuffer, the shader and
the GL state. dentdemo only adds a height and a normal map to a mesh and carves into them; the
host binds the normal map when it shades. Run:

    python examples/carve_in_your_context.py --out dent.png

Without a display the context is a headless EGL one; inside a window, pass your own context.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import moderngl
import numpy as np
import trimesh
from PIL import Image

import dentdemo

# The host's own shader: Lambert light with the surface normal bent by dentdemo's normal map
# (tangent space, xyz * 0.5 + 0.5) in the mesh's own tangent frame: T = in_tangent.xyz along +u,
# B = cross(N, T) * in_tangent.w (see help(dentdemo.Mesh)).
VERTEX = """
#version 330 core
uniform mat4 u_mvp;
in vec3 in_position;
in vec3 in_normal;
in vec4 in_tangent;
in vec2 in_uv;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv;
void main() {
    v_normal = in_normal;
    v_tangent = in_tangent;
    v_uv = in_uv;
    gl_Position = u_mvp * vec4(in_position, 1.0);
}
"""
FRAGMENT = """
#version 330 core
uniform sampler2D u_normal_map;
uniform vec3 u_light;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
out vec4 f_colour;
void main() {
    vec3 n = normalize(v_normal);
    vec3 t = normalize(v_tangent.xyz - n * dot(n, v_tangent.xyz));
    vec3 b = cross(n, t) * v_tangent.w;
    vec3 m = texture(u_normal_map, v_uv).xyz * 2.0 - 1.0;
    vec3 bent = normalize(mat3(t, b, n) * m);
    float light = 0.15 + 0.85 * max(dot(bent, normalize(-u_light)), 0.0);
    f_colour = vec4(vec3(0.85, 0.55, 0.35) * light, 1.0);
}
"""


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    f = np.subtract(target, eye)
    f = f / np.linalg.norm(f)
    s = np.cross(f, up)
    s = s / np.linalg.norm(s)
    u = np.cross(s, f)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = s, u, -f
    view[:3, 3] = -view[:3, :3] @ eye
    return view


def perspective(fov_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    f = 1.0 / np.tan(np.radians(fov_deg) / 2)
    out = np.zeros((4, 4))
    out[0, 0], out[1, 1] = f / aspect, f
    out[2, 2], out[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
    out[3, 2] = -1.0
    return out


def run(
    ctx: moderngl.Context,
    out: Path,
    press: bool = True,
    size=(480, 360),
    gltf: Path | None = None,
) -> dict:
    """Make a torus, dent it with a ball (unless `press` is False), render it to `out` and,
    with `gltf`, export it there (glTF 2.0: Blender, web viewers) with its normal map."""
    # A trimesh torus without texture coordinates, lying flat (axis +Y): dentdemo gives it a
    # unique atlas (one warning). dentdemo.mesh_from_triangles(positions, indices, uvs) does the
    # same for a host's own arrays.
    torus = trimesh.creation.torus(major_radius=0.2, minor_radius=0.07)
    torus.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, (1, 0, 0)))
    target = dentdemo.DentableSurface(ctx, torus, map_size=1024, max_dent_depth=0.02)

    # A 5 cm ball touching the top of the tube at (0.2, 0.07, 0), moving straight down.
    top = np.array([0.2, 0.07, 0.0])
    ball = dentdemo.DentableSurface(ctx, dentdemo.shape_mesh(dentdemo.Sphere(0.05)), 256)
    ball.model = np.eye(4)
    ball.model[:3, 3] = top + [0.0, 0.05, 0.0]
    carver = dentdemo.Carver(ctx)
    pressed = press and carver.press(
        target, ball, dentdemo.Contact(top, (0.0, -1.0, 0.0)), depth=0.006
    )
    depth = float(-target.heights().min())

    # The host's frame: its own framebuffer, program and state.
    fbo = ctx.framebuffer([ctx.renderbuffer(size, 4, samples=0)], ctx.depth_renderbuffer(size))
    fbo.use()
    fbo.clear(0.1, 0.12, 0.15, 1.0, depth=1.0)
    ctx.enable(moderngl.DEPTH_TEST)
    prog = ctx.program(vertex_shader=VERTEX, fragment_shader=FRAGMENT)
    # Draw target.mesh, not the torus's own arrays: its vertices are split along the new atlas's
    # seams (mesh.source_vertex names the torus vertex each one copies, for any data of the
    # host's own per vertex).
    mesh = target.mesh
    data = np.hstack([mesh.positions, mesh.normals, mesh.tangents, mesh.uvs]).astype("f4")
    vbo = ctx.buffer(data.tobytes())
    ibo = ctx.buffer(mesh.indices.astype("u4").tobytes())
    names = ("in_position", "in_normal", "in_tangent", "in_uv")
    vao = ctx.vertex_array(prog, [(vbo, "3f 3f 4f 2f", *names)], ibo)
    mvp = perspective(35.0, size[0] / size[1], 0.05, 5.0) @ look_at((0.3, 0.32, 0.22), top)
    prog["u_mvp"].write(mvp.T.astype("f4").tobytes())
    prog["u_light"].value = (-0.3, -1.0, -0.6)
    target.normal.use(0)
    prog["u_normal_map"].value = 0
    vao.render()
    pixels = np.frombuffer(fbo.read(components=3), dtype=np.uint8).reshape(size[1], size[0], 3)
    Image.fromarray(pixels[::-1]).save(out)

    if gltf is not None:
        dentdemo.export_gltf(
            gltf, [target, ball], names=["torus", "ball"], looks=["copper", "steel"]
        )

    for thing in (vao, prog, vbo, ibo, fbo, carver, ball, target):
        thing.release()
    return {"pressed": bool(pressed), "depth_m": depth, "image": str(out)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="dent.png", help="image to write")
    parser.add_argument("--no-press", action="store_true", help="render without the dent")
    parser.add_argument("--gltf", type=Path, help="also export the torus and the ball (.glb)")
    args = parser.parse_args()
    ctx = moderngl.create_context(standalone=True, backend="egl", require=330)
    print(run(ctx, Path(args.out), press=not args.no_press, gltf=args.gltf))


if __name__ == "__main__":
    main()
