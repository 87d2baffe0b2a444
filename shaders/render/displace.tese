#version 400 core
// The points displace.tesc asks for: mesh attributes interpolated across the triangle (as the
// fallback mesh of render/refine.py does on the CPU), the position moved along the normal by the
// height map; on the triangle's corners and seam edges by the deepest of the charts that meet
// there (displace.glsl), as the neighbouring triangle does. SHADOW 1: depth from the sun only.
#ifndef SHADOW
#define SHADOW 0
#endif
#ifndef DISPLACE
#define DISPLACE 2
#endif
layout(triangles, equal_spacing, ccw) in;
#include "frame.glsl"
#include "displace.glsl"

in vec3 te_position[];  // local metres
in vec3 te_normal[];
in vec2 te_uv[];
in vec4 te_twin_uv[];
#if !SHADOW
in vec4 te_tangent[];
in vec2 te_texture_uv[];
#include "surface_vertex.glsl"
#else
uniform mat4 u_model;  // world from local
#endif

#define BLEND(a) (gl_TessCoord.x * a[0] + gl_TessCoord.y * a[1] + gl_TessCoord.z * a[2])

// Metres along the normal at tessellation coordinate b, address uv.
float patch_height(vec3 b, vec2 uv) {
    for (int k = 0; k < 3; ++k) {
        if (b[k] == 1.0) return seam_height(te_uv[k], te_twin_uv[k]);  // a corner
    }
    for (int k = 0; k < 3; ++k) {
        int i = (k + 1) % 3, j = (k + 2) % 3;
        vec2 ta, tb;
        if (b[k] == 0.0 && seam_edge(te_uv[i], te_twin_uv[i], te_uv[j], te_twin_uv[j], ta, tb)) {
            return min(height_at(uv), height_at(b[i] * ta + b[j] * tb));
        }
    }
    return height_at(uv);
}

void main() {
    vec3 position = BLEND(te_position);
    vec3 normal = normalize(BLEND(te_normal));
    vec2 uv = BLEND(te_uv);
#if SHADOW
    float height = patch_height(gl_TessCoord, uv);
    gl_Position = u_light_view_proj * u_model * vec4(position + normal * height, 1.0);
#else
    vec4 tangent = vec4(normalize(BLEND(te_tangent).xyz), te_tangent[0].w);
    emit_surface(position, normal, uv, tangent, BLEND(te_texture_uv), patch_height(gl_TessCoord, uv));
#endif
}
