#version 400 core
// The points displace.tesc asks for: mesh attributes interpolated across the triangle (as the
// fallback mesh of render/refine.py does on the CPU), the position moved along the normal by the
// height map. SHADOW 1: depth from the sun only.
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
#if !SHADOW
in vec4 te_tangent[];
in vec2 te_texture_uv[];
#include "surface_vertex.glsl"
#else
uniform mat4 u_model;  // world from local
#endif

#define BLEND(a) (gl_TessCoord.x * a[0] + gl_TessCoord.y * a[1] + gl_TessCoord.z * a[2])

void main() {
    vec3 position = BLEND(te_position);
    vec3 normal = normalize(BLEND(te_normal));
    vec2 uv = BLEND(te_uv);
#if SHADOW
    gl_Position = u_light_view_proj * u_model * vec4(displaced(position, normal, uv), 1.0);
#else
    vec4 tangent = vec4(normalize(BLEND(te_tangent).xyz), te_tangent[0].w);
    emit_surface(position, normal, uv, tangent, BLEND(te_texture_uv), height_at(uv));
#endif
}
