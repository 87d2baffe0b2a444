#version 330 core
// Passes 2 and 3: a body's mesh seen by the collision camera. TILED 1 (pass 3's): drawn instanced
// over the jobs that draw one tool mesh (instance i: the job table's entry u_job + i, handed on to
// peel.geom), each placed in its camera's tile of the scratch atlas (ATLAS: its pixels) here and
// clipped to the tile's pixel edges by peel.geom, drawn with the whole atlas as the viewport.
// TILED 0: drawn with the tile as the viewport.
#ifndef TILED
#define TILED 0
#endif
#if TILED
#define JOB (u_job + gl_InstanceID)
#endif
#include "camera.glsl"

#if PLANE  // pass 3's triangles go through peel.geom, which takes these as its inputs
#define v_uv g_uv
#define v_depth g_depth
#define v_normal g_normal
#define v_world g_world
#endif

// u_model, u_normal_matrix and u_near_clip (pass 2's clip distance 0: no surface nearer than
// this view depth, metres: it lies behind the tool; docs/carve.md): the job's entry (job.glsl).

in vec3 in_position;  // local metres
in vec3 in_normal;    // local, unit
in vec2 in_uv;        // the body's surface-map address

out vec2 v_uv;
out float v_depth;    // metres along u_forward from u_eye
out vec3 v_normal;    // world
out vec3 v_world;     // world metres
#if PLANE
out vec2 g_ndc;       // the tile's normalised device coordinates (peel.geom clips to the tile)
#else
// Every carve pass enables CLIP_DISTANCES: 0 the near clip, the rest unused.
out float gl_ClipDistance[CLIP_DISTANCES];
#endif
#if TILED
flat out int g_job;   // the entry this instance reads
#endif

void main() {
    vec3 world = (u_model * vec4(in_position, 1.0)).xyz;
    vec3 rel = world - u_eye;
    v_uv = in_uv;
    v_depth = dot(rel, u_forward);
    v_normal = u_normal_matrix * in_normal;
    v_world = world;
    float z = 2.0 * (v_depth - u_depth_range.x) / (u_depth_range.y - u_depth_range.x) - 1.0;
    vec2 ndc = vec2(dot(rel, u_right) / u_half_extent.x, dot(rel, u_up) / u_half_extent.y);
#if PLANE
    g_ndc = ndc;
#else
    for (int k = 1; k < CLIP_DISTANCES; ++k) gl_ClipDistance[k] = 1.0;
    gl_ClipDistance[0] = v_depth - u_near_clip;
#endif
#if TILED
    g_job = JOB;
    vec2 pixel = vec2(u_tile) + (ndc * 0.5 + 0.5) * vec2(u_resolution);
    gl_Position = vec4(pixel / ATLAS * 2.0 - 1.0, z, 1.0);
#else
    gl_Position = vec4(ndc, z, 1.0);
#endif
}
