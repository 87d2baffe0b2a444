#version 330 core
// ---- Pass 3: the tool's extent along each view line ---------------------------------------------
// The tool's faces, both sides, each depth moved by the tool's own height map (bump-to-depth, the
// height bilinear between texels as the renderer draws it; a built-in sphere or capsule: where
// the view line enters or leaves its smooth surface), blended
// into one RGBA32F pixel per view line without a depth test: red keeps the farthest back face
// (MAX: the deepest point the tool reaches along the view), green the coverage (MAX: 1 where the
// tool is), alpha the nearest front face (MIN). Pass 4 compares the back with every target texel
// at the texel's own centre; pass 2 drops target surfaces in front of the front. Where the tool is
// absent: (NO_TOOL, NO_TOOL, -, NO_FRONT).
#if QUAD || TILED  // drawn instanced (quad.vert, peel.geom): the entry from the stage before
flat in int v_job;
#define JOB v_job
#endif
#include "camera.glsl"
#include "../include/texel.glsl"
#include "../include/bump_depth.glsl"
#include "swept.glsl"

uniform sampler2D u_height;  // tool height map, R32F metres

out vec4 f_tool;  // (back view depth m, coverage 1, 0, front view depth m)

#if QUAD  // a built-in sphere or capsule as one quad: both faces of the exact solid in one fragment
#include "quad_uv.glsl"

// The bumped view depth where the pixel's view line enters (or leaves) the solid.
float bumped_at(vec3 line, float depth) {
    vec3 p = line + u_forward * depth, n;
    swept_snap(p, n);
    return bumped_depth(depth, height_at(u_height, quad_uv(p)), n, u_forward);
}

void main() {
    vec3 line = camera_line(gl_FragCoord.xy);
    float enter = swept_view_depth(line, -1e30, false, u_eye, u_forward);
    if (enter < -1e29) discard;  // the view line misses the solid
    float leave = swept_view_depth(line, enter, true, u_eye, u_forward);
    f_tool = vec4(bumped_at(line, leave), 1.0, 0.0, bumped_at(line, enter));
}
#else
in vec2 v_uv;
in float v_depth;
in vec3 v_normal;
in vec3 v_world;
flat in vec3 t_world[3];   // peel.geom: the triangle's corners, world metres
flat in vec2 t_uv[3];
flat in vec3 t_normal[3];  // world

// The view depth, uv and normal where the pixel's view line meets the triangle's plane, from the
// pixel's index (camera_line) and the corners alone: the same bits in any tile. An edge-on
// triangle keeps the interpolated values.
void on_plane(inout float depth, inout vec2 uv, inout vec3 n) {
    vec3 e1 = t_world[1] - t_world[0], e2 = t_world[2] - t_world[0];
    vec3 face = cross(e1, e2);
    float den = dot(face, u_forward);
    if (abs(den) <= 1e-6 * length(face)) return;
    vec3 line = camera_line(gl_FragCoord.xy);  // at view depth 0
    depth = dot(face, t_world[0] - line) / den;
    vec3 q = line + u_forward * depth - t_world[0];
    float area = dot(face, face);
    float b1 = dot(cross(q, e2), face) / area, b2 = dot(cross(e1, q), face) / area;
    float b0 = 1.0 - b1 - b2;
    uv = b0 * t_uv[0] + b1 * t_uv[1] + b2 * t_uv[2];
    n = normalize(b0 * t_normal[0] + b1 * t_normal[1] + b2 * t_normal[2]);
}

void main() {
    float depth = v_depth;
    vec2 uv = v_uv;
    vec3 n = normalize(v_normal);
    on_plane(depth, uv, n);
    float h_tool = height_at(u_height, uv);
    bool back = !gl_FrontFacing;
#if SWEPT  // a built-in sphere or capsule: where the view line enters or leaves its smooth surface
    {
        vec3 line = camera_line(gl_FragCoord.xy);  // exact: the same bits in any tile
        depth = swept_view_depth(line, depth, back, u_eye, u_forward);
        vec3 p = line + u_forward * depth;
        swept_snap(p, n);
    }
#endif
    depth = bumped_depth(depth, h_tool, n, u_forward);
    f_tool = back ? vec4(depth, 1.0, 0.0, NO_FRONT) : vec4(NO_TOOL, 1.0, 0.0, depth);
}
#endif
