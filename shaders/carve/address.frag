#version 330 core
// ---- Pass 2: the address map ----------------------------------------------------------------------
// The target's front faces. Colour = (u, v) of the target's surface map (the paper's address map)
// plus the view depth of the unbumped surface and the bumped one. The depth test runs on the depth
// moved by the target's current height (bump-to-depth), so existing dents count in what is in front.
#include "camera.glsl"
#include "../include/texel.glsl"
#include "../include/bump_depth.glsl"

uniform sampler2D u_height;  // target height map, R32F metres

in vec2 v_uv;
in float v_depth;    // view depth of the mesh surface, metres
in vec3 v_normal;

layout(location = 0) out vec4 f_address;  // (u, v, view depth, bumped view depth), metres

void main() {
    ivec2 size = textureSize(u_height, 0);
    float h = texelFetch(u_height, texel_of(v_uv, size), 0).r;
    float bumped = bumped_depth(v_depth, h, normalize(v_normal), u_forward);
    gl_FragDepth = window_depth(bumped);
    f_address = vec4(v_uv, v_depth, bumped);
}
