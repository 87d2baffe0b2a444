#version 400 core
// Adaptive tessellation of a dentable body (patches are its triangles). An edge is cut into
// segments of about u_segment_pixels where the height map holds a dent (or bump) at least
// u_deep_pixels deep along it, and left whole elsewhere, so flat areas stay one triangle and
// shallow dents stay in the normal map (and parallax). An edge's level depends on that edge alone
// (its ends, taken in a fixed order of position, and samples along it in both charts where it is
// a seam), so the two triangles that share it agree and no crack opens. Lengths are counted in pixels as if the edge faced the view, so
// edges seen edge-on at a silhouette, where the outline is made, are cut as finely as any.
// SHADOW 1: the shadow pass (position, normal and address only).
#ifndef SHADOW
#define SHADOW 0
#endif
layout(vertices = 3) out;
#include "displace.glsl"

uniform mat4 u_model;             // world from local
uniform mat4 u_tess_view_proj;    // clip from world of this pass (the camera's or the sun's)
uniform float u_pixels_per_metre; // this pass's pixels per metre at clip w = 1
uniform float u_segment_pixels;   // wanted segment length, pixels
uniform float u_max_level;        // most segments per edge
uniform float u_deep_pixels;      // shallower dents are not displaced, pixels

in vec3 tc_position[];  // local metres
in vec3 tc_normal[];
in vec2 tc_uv[];
in vec4 tc_twin_uv[];
out vec3 te_position[];
out vec3 te_normal[];
out vec2 te_uv[];
out vec4 te_twin_uv[];
#if !SHADOW
in vec4 tc_tangent[];
in vec2 tc_texture_uv[];
out vec4 te_tangent[];
out vec2 te_texture_uv[];
#endif

// Pixels per metre at a local point (nearer: more).
float pixels_per_metre(vec3 local) {
    float w = (u_tess_view_proj * (u_model * vec4(local, 1.0))).w;
    return u_pixels_per_metre / max(w, 1e-3);
}

// Segments for a stretch of `metres` holding a dent `depth` metres deep, at `scale` pixels/m.
float level(float metres, float depth, float scale) {
    if (depth * scale < u_deep_pixels) return 1.0;
    return clamp(ceil(metres * scale / u_segment_pixels), 1.0, u_max_level);
}

// Whether local point p comes before q (a fixed order that both triangles of an edge share).
bool before(vec3 p, vec3 q) {
    return p.x < q.x || (p.x == q.x && (p.y < q.y || (p.y == q.y && p.z < q.z)));
}

// The level of the edge between corners i and j.
float edge_level(int i, int j) {
    int a = before(tc_position[i], tc_position[j]) ? i : j, b = a == i ? j : i;
    vec2 ta, tb;  // the ends' addresses across a seam (the same as theirs elsewhere)
    if (!seam_edge(tc_uv[a], tc_twin_uv[a], tc_uv[b], tc_twin_uv[b], ta, tb)) {
        ta = tc_uv[a];
        tb = tc_uv[b];
    }
    float depth = 0.0;
    for (int k = 0; k <= 4; ++k) {  // five samples: the ends, the quarters and the middle
        float t = float(k) * 0.25;
        depth = max(depth, abs(height_at(mix(tc_uv[a], tc_uv[b], t))));
        depth = max(depth, abs(height_at(mix(ta, tb, t))));
    }
    float scale = max(pixels_per_metre(tc_position[a]), pixels_per_metre(tc_position[b]));
    float metres = length(mat3(u_model) * (tc_position[b] - tc_position[a]));
    return level(metres, depth, scale);
}

void main() {
    te_position[gl_InvocationID] = tc_position[gl_InvocationID];
    te_normal[gl_InvocationID] = tc_normal[gl_InvocationID];
    te_uv[gl_InvocationID] = tc_uv[gl_InvocationID];
    te_twin_uv[gl_InvocationID] = tc_twin_uv[gl_InvocationID];
#if !SHADOW
    te_tangent[gl_InvocationID] = tc_tangent[gl_InvocationID];
    te_texture_uv[gl_InvocationID] = tc_texture_uv[gl_InvocationID];
#endif
    if (gl_InvocationID != 0) return;
    // GL's order: outer[0] is the edge opposite corner 0 (1-2), outer[1] 2-0, outer[2] 0-1.
    float e0 = edge_level(1, 2), e1 = edge_level(2, 0), e2 = edge_level(0, 1);
    // Inside: four samples (the centre and halfway to each corner) for a dent no edge meets.
    vec2 centre = (tc_uv[0] + tc_uv[1] + tc_uv[2]) / 3.0;
    float depth = abs(height_at(centre));
    for (int k = 0; k < 3; ++k) depth = max(depth, abs(height_at(mix(centre, tc_uv[k], 0.5))));
    float longest = 0.0, scale = 0.0;
    for (int k = 0; k < 3; ++k) {
        longest = max(longest, length(mat3(u_model) * (tc_position[(k + 1) % 3] - tc_position[k])));
        scale = max(scale, pixels_per_metre(tc_position[k]));
    }
    gl_TessLevelOuter[0] = e0;
    gl_TessLevelOuter[1] = e1;
    gl_TessLevelOuter[2] = e2;
    gl_TessLevelInner[0] = max(max(e0, max(e1, e2)), level(longest, depth, scale));
}
