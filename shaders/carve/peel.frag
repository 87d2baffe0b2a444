#version 330 core
// ---- Pass 3: depth peel of the tool ---------------------------------------------------------------
// The tool's back faces, depth moved by the tool's own height map, drawn with the address pass's
// depth buffer and the test "farther than the target" (GL_GREATER), so where a fragment survives the
// tool reaches past the target's surface. Output: the target texel's new height, metres.
#include "camera.glsl"
#include "../include/texel.glsl"
#include "../include/bump_depth.glsl"

const float MIN_COS = 0.2;  // grazing surfaces: cap the depth-to-height stretch at 1/MIN_COS

uniform sampler2D u_height;     // tool height map, R32F metres
uniform sampler2D u_address;    // pass 2: (u, v, target height, cos)
uniform sampler2D u_depth_a;    // pass 2: target's bumped depth, metres
uniform float u_min_height;     // -max_dent_depth of the target, metres

in vec2 v_uv;
in float v_depth;
in vec3 v_normal;

out float f_height;

void main() {
    ivec2 size = textureSize(u_height, 0);
    float h_tool = texelFetch(u_height, texel_of(v_uv, size), 0).r;
    float depth = bumped_depth(v_depth, h_tool, normalize(v_normal), u_forward);
    gl_FragDepth = window_depth(depth);
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 address = texelFetch(u_address, pixel, 0);
    float penetration = depth - texelFetch(u_depth_a, pixel, 0).r;  // metres along the view
    if (!(penetration > 0.0) || address.x < 0.0) discard;
    // The target point moves along its normal until its bumped depth meets the tool's.
    float h_new = address.z - penetration / max(address.w, MIN_COS);
    f_height = max(h_new, u_min_height);
}
