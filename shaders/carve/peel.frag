#version 330 core
// ---- Pass 3: the tool's extent along each view line ---------------------------------------------
// The tool's faces, both sides, each depth moved by the tool's own height map (bump-to-depth; a
// built-in sphere or capsule: where the view line enters or leaves its smooth surface), blended
// into one RGBA32F pixel per view line without a depth test: red keeps the farthest back face
// (MAX: the deepest point the tool reaches along the view), green the coverage (MAX: 1 where the
// tool is), alpha the nearest front face (MIN). Pass 4 compares the back with every target texel
// at the texel's own centre; pass 2 drops target surfaces in front of the front. Where the tool is
// absent: (NO_TOOL, NO_TOOL, -, NO_FRONT).
#include "camera.glsl"
#include "../include/texel.glsl"
#include "../include/bump_depth.glsl"
#include "swept.glsl"

uniform sampler2D u_height;  // tool height map, R32F metres

in vec2 v_uv;
in float v_depth;
in vec3 v_normal;
in vec3 v_world;

out vec4 f_tool;  // (back view depth m, coverage 1, 0, front view depth m)

void main() {
    ivec2 size = textureSize(u_height, 0);
    float h_tool = texelFetch(u_height, texel_of(v_uv, size), 0).r;
    bool back = !gl_FrontFacing;
    float depth = v_depth;
    vec3 n = normalize(v_normal);
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
