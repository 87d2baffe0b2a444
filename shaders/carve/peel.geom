#version 330 core
// Pass 3, a tool drawn as its triangles: each triangle passed through with its three corners as
// flat values, so that peel.frag finds a pixel's depth, uv and normal where the pixel's own view
// line meets the triangle's plane (from the pixel's index in its tile). The rasteriser's
// interpolation rounds by the window position, so a tool's values would depend on where the
// camera's tile lies in the atlas, that is, on the rest of the batch.
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

in vec2 g_uv[];
in float g_depth[];
in vec3 g_normal[];
in vec3 g_world[];

out vec2 v_uv;
out float v_depth;
out vec3 v_normal;
out vec3 v_world;
flat out vec3 t_world[3];   // world metres
flat out vec2 t_uv[3];      // the tool's surface-map address
flat out vec3 t_normal[3];  // world, vertex normals

void main() {
    for (int k = 0; k < 3; ++k) {
        for (int i = 0; i < 3; ++i) {
            t_world[i] = g_world[i];
            t_uv[i] = g_uv[i];
            t_normal[i] = g_normal[i];
        }
        v_uv = g_uv[k];
        v_depth = g_depth[k];
        v_normal = g_normal[k];
        v_world = g_world[k];
        gl_Position = gl_in[k].gl_Position;
        EmitVertex();
    }
    EndPrimitive();
}
