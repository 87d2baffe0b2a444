#version 330 core
// Passes 2 and 3: a body's mesh seen by the collision camera.
#include "camera.glsl"

#if PLANE  // pass 3's triangles go through peel.geom, which takes these as its inputs
#define v_uv g_uv
#define v_depth g_depth
#define v_normal g_normal
#define v_world g_world
#endif

// u_model, u_normal_matrix and u_near_clip (pass 2's one clip distance: no surface nearer than
// this view depth, metres: it lies behind the tool; docs/carve.md): the job's entry (job.glsl).

in vec3 in_position;  // local metres
in vec3 in_normal;    // local, unit
in vec2 in_uv;        // the body's surface-map address

out vec2 v_uv;
out float v_depth;    // metres along u_forward from u_eye
out vec3 v_normal;    // world
out vec3 v_world;     // world metres
out float gl_ClipDistance[1];

void main() {
    vec3 world = (u_model * vec4(in_position, 1.0)).xyz;
    vec3 rel = world - u_eye;
    v_uv = in_uv;
    v_depth = dot(rel, u_forward);
    v_normal = u_normal_matrix * in_normal;
    v_world = world;
    gl_ClipDistance[0] = v_depth - u_near_clip;
    float z = 2.0 * (v_depth - u_depth_range.x) / (u_depth_range.y - u_depth_range.x) - 1.0;
    gl_Position = vec4(dot(rel, u_right) / u_half_extent.x, dot(rel, u_up) / u_half_extent.y, z, 1.0);
}
