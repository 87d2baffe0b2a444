#version 330 core
// ---- Pass 3: depth peel of the tool's back faces ------------------------------------------------
// The tool's back faces, depth moved by the tool's own height map (bump-to-depth), with the depth
// test "farther" (GL_GREATER) from a buffer cleared to the near plane: each pixel keeps the deepest
// point the tool reaches along the view. Pass 4 compares it with every target texel at the texel's
// own centre. Output: that bumped view depth, metres; NO_CHANGE where the tool is absent.
#include "camera.glsl"
#include "../include/texel.glsl"
#include "../include/bump_depth.glsl"

uniform sampler2D u_height;  // tool height map, R32F metres

in vec2 v_uv;
in float v_depth;
in vec3 v_normal;

out float f_tool_depth;

void main() {
    ivec2 size = textureSize(u_height, 0);
    float h_tool = texelFetch(u_height, texel_of(v_uv, size), 0).r;
    float depth = bumped_depth(v_depth, h_tool, normalize(v_normal), u_forward);
    gl_FragDepth = window_depth(depth);
    f_tool_depth = depth;
}
