#version 330 core
// ---- Pass 3: depth peel of the tool's back faces ------------------------------------------------
// The tool's back faces (a built-in sphere or capsule: where the view line leaves its smooth
// surface), depth moved by the tool's own height map (bump-to-depth), with the depth
// test "farther" (GL_GREATER) from a buffer cleared to the near plane: each pixel keeps the deepest
// point the tool reaches along the view. Pass 4 compares it with every target texel at the texel's
// own centre. Output: (that bumped view depth in metres, coverage 1); NO_TOOL (0, 0) where the
// tool is absent.
#include "camera.glsl"
#include "../include/texel.glsl"
#include "../include/bump_depth.glsl"
#include "swept.glsl"

uniform sampler2D u_height;  // tool height map, R32F metres

in vec2 v_uv;
in float v_depth;
in vec3 v_normal;
in vec3 v_world;

out vec2 f_tool;  // (bumped view depth, metres; 1: the tool is here)

void main() {
    ivec2 size = textureSize(u_height, 0);
    float h_tool = texelFetch(u_height, texel_of(v_uv, size), 0).r;
    float depth = v_depth;
    vec3 n = normalize(v_normal);
#if SWEPT  // a built-in sphere or capsule: where the view line leaves its smooth surface
    {
        depth = swept_view_depth(v_world, depth, true, u_eye, u_forward);
        vec3 p = u_eye + u_forward * depth + (v_world - u_eye - u_forward * v_depth);
        swept_snap(p, n);
    }
#endif
    depth = bumped_depth(depth, h_tool, n, u_forward);
    gl_FragDepth = window_depth(depth);
    f_tool = vec2(depth, 1.0);
}
