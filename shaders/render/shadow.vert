#version 330 core
// Depth from the light for the shadow map. DISPLACE as in lit.vert: the shadow moves with the
// surface.
#ifndef DISPLACE
#define DISPLACE 0
#endif
in vec3 in_position;   // local metres
in vec3 in_normal;
in vec2 in_uv;
#if DISPLACE
in vec4 in_twin_uv;  // the vertex's addresses in other charts (render/seams.py)
#endif

#if DISPLACE == 2
out vec3 tc_position;
out vec3 tc_normal;
out vec2 tc_uv;
out vec4 tc_twin_uv;

void main() {
    tc_position = in_position;
    tc_normal = in_normal;
    tc_uv = in_uv;
    tc_twin_uv = in_twin_uv;
}
#else
#include "frame.glsl"
uniform mat4 u_model;  // world from local
#if DISPLACE
#include "displace.glsl"
#endif

void main() {
#if DISPLACE
    vec3 p = in_position + normalize(in_normal) * seam_height(in_uv, in_twin_uv);
#else
    vec3 p = in_position;
#endif
    gl_Position = u_light_view_proj * u_model * vec4(p, 1.0);
}
#endif
