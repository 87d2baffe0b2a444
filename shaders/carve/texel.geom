#version 330 core
// Passes 4 and 5, gutter draws: each chart-border triangle becomes its texel bounding box grown by
// one texel, clipped to the footprint, carrying the whole triangle to the fragment shader, which
// keeps the gutter texels that overlap the triangle (texel.glsl).
flat in int g_job[];  // texel.vert: the job table's entry of the instance
#define JOB g_job[0]
#include "camera.glsl"
#include "clip.glsl"

layout(triangles) in;
layout(triangle_strip, max_vertices = 4) out;

// u_map_size (surface-map texels): the job's entry (job.glsl).

in vec3 g_world[];
in vec3 g_normal[];
in vec2 g_uv[];
in float g_thickness[];

flat out vec2 t_uv[3];      // triangle corners, texel units
flat out vec3 t_world[3];   // world metres
flat out vec3 t_normal[3];  // world, vertex normals
flat out float t_thickness[3];  // world metres
flat out int v_job;  // the entry, for the fragment stage

void main() {
    vec2 size = vec2(u_map_size);
    vec2 p0 = g_uv[0] * size, p1 = g_uv[1] * size, p2 = g_uv[2] * size;
    vec2 e1 = p1 - p0, e2 = p2 - p0;
    float den = e1.x * e2.y - e1.y * e2.x;
    if (abs(den) < 1e-12) return;  // no area in texture space
    vec2 lo = floor(min(p0, min(p1, p2))) - 1.0, hi = ceil(max(p0, max(p1, p2))) + 1.0;
    vec2 corners[4] = vec2[4](lo, vec2(hi.x, lo.y), vec2(lo.x, hi.y), hi);
    for (int k = 0; k < 4; ++k) {
        for (int i = 0; i < 3; ++i) {
            t_uv[i] = g_uv[i] * size;
            t_world[i] = g_world[i];
            t_normal[i] = g_normal[i];
            t_thickness[i] = g_thickness[i];
        }
        v_job = JOB;
        // The corner's point on the triangle's plane (affine extension), for the clip distances.
        vec2 q = corners[k] - p0;
        float b1 = (q.x * e2.y - q.y * e2.x) / den, b2 = (e1.x * q.y - e1.y * q.x) / den;
        clip_to_footprint(g_world[0] + b1 * (g_world[1] - g_world[0]) + b2 * (g_world[2] - g_world[0]));
        gl_Position = vec4(corners[k] / size * 2.0 - 1.0, 0.0, 1.0);
        EmitVertex();
    }
    EndPrimitive();
}
