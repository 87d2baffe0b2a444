#version 330 core
// Scene bodies: world position, texture address and tangent frame for normal mapping.
// DISPLACE 0: the mesh as it is; 1: each vertex moved along its normal by the height map (the
// finer fallback mesh); 2: the mesh handed to the tessellation stages (displace.tesc, .tese),
// which cut it where dents are deep and move the new vertices.
#ifndef DISPLACE
#define DISPLACE 0
#endif

in vec3 in_position;  // local metres
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;   // xyz along +u, w = handedness
in vec2 in_texture_uv;  // where the mesh's own base-colour image is sampled
#if DISPLACE
in vec4 in_twin_uv;     // the vertex's addresses in other charts (render/seams.py)
#endif

#if DISPLACE == 2
out vec3 tc_position;
out vec3 tc_normal;
out vec2 tc_uv;
out vec4 tc_tangent;
out vec2 tc_texture_uv;
out vec4 tc_twin_uv;

void main() {
    tc_position = in_position;
    tc_normal = in_normal;
    tc_uv = in_uv;
    tc_tangent = in_tangent;
    tc_texture_uv = in_texture_uv;
    tc_twin_uv = in_twin_uv;
}
#else
#include "frame.glsl"
#include "surface_vertex.glsl"
#if DISPLACE
#include "displace.glsl"
#define HEIGHT seam_height(in_uv, in_twin_uv)
#else
#define HEIGHT 0.0
#endif

void main() { emit_surface(in_position, in_normal, in_uv, in_tangent, in_texture_uv, HEIGHT); }
#endif
