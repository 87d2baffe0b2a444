#version 330 core
// ---- Pass 2: the address map --------------------------------------------------------------------
// The target's front faces, colour = (u, v) of the target's surface map, plus its current height at
// that texel and the cosine between surface normal and view. Depth is moved by the current height
// (bump-to-depth), so existing dents count.
#include "camera.glsl"
#include "../include/texel.glsl"
#include "../include/bump_depth.glsl"

uniform sampler2D u_height;  // target height map, R32F metres

in vec2 v_uv;
in float v_depth;
in vec3 v_normal;

layout(location = 0) out vec4 f_address;  // (u, v, height in m, cos(normal, -forward))
layout(location = 1) out float f_depth;   // bumped view depth, metres

void main() {
    ivec2 size = textureSize(u_height, 0);
    float h = texelFetch(u_height, texel_of(v_uv, size), 0).r;
    vec3 n = normalize(v_normal);
    float depth = bumped_depth(v_depth, h, n, u_forward);
    gl_FragDepth = window_depth(depth);
    f_address = vec4(v_uv, h, max(-dot(n, u_forward), 0.0));
    f_depth = depth;
}
