#version 330 core
// Passes 4 and 5: the target's triangles drawn at their texture coordinates, so that every
// fragment is one texel of the surface map (row 0 is v = 0). GUTTER 0 draws the triangles as they
// are, clipped to the footprint here: each texel centre inside a chart is covered exactly once.
// GUTTER 1 hands them to texel.geom, which draws the gutter texels around the chart borders.
// Drawn instanced over the jobs that dent one map with one triangle list (carve/carver.py): instance
// i is the job table's entry u_job + i, handed on to the later stages.
#define JOB (u_job + gl_InstanceID)
#include "camera.glsl"

#ifndef GUTTER
#define GUTTER 0
#endif

// u_model (world from local) and u_normal_matrix: the job's entry (job.glsl).

in vec3 in_position;  // local metres
in vec3 in_normal;    // local, unit
in vec2 in_uv;        // the body's surface-map address
in float in_thickness;  // the body's thickness under the vertex, local metres (pass 4 only)

#if GUTTER
out vec3 g_world;     // world metres
out vec3 g_normal;    // world
out vec2 g_uv;
out float g_thickness;  // world metres
flat out int g_job;   // the entry this instance reads
#else
#include "clip.glsl"
out vec3 v_world;     // world metres
out vec3 v_normal;    // world
out float v_thickness;  // world metres
flat out int v_job;   // the entry this instance reads
#endif

void main() {
    vec3 world = (u_model * vec4(in_position, 1.0)).xyz;
    vec3 normal = u_normal_matrix * in_normal;
    float thickness = in_thickness * length(u_model[0].xyz);  // a pose scales uniformly
#if GUTTER
    g_world = world;
    g_normal = normal;
    g_uv = in_uv;
    g_thickness = thickness;
    g_job = JOB;
#else
    v_world = world;
    v_normal = normal;
    v_thickness = thickness;
    v_job = JOB;
    clip_to_footprint(world);
#endif
    gl_Position = vec4(in_uv * 2.0 - 1.0, 0.0, 1.0);
}
