#version 330 core
// ---- Pass 2: the address map ----------------------------------------------------------------------
// The target's front faces. Colour = (u, v) of the target's surface map (the paper's address map)
// plus the view depth of the unbumped surface and the bumped one (a built-in sphere or capsule:
// of its smooth surface along the pixel's view line). The depth test runs on the depth
// moved by the target's current height (bump-to-depth), so existing dents count in what is in front.
// A surface in front of the tool's nearest point at first touch (pass 3's front, less the advance)
// lies behind the tool, outside anything it sweeps: it is dropped, so it neither hides the surface
// the tool meets nor takes a dent (a shelf over the tool, a ledge overhanging it).
#if QUAD  // drawn instanced (quad.vert): the entry comes from the vertex stage
flat in int v_job;
#define JOB v_job
#endif
#include "camera.glsl"
#include "../include/texel.glsl"
#include "../include/bump_depth.glsl"
#include "swept.glsl"

uniform sampler2D u_height;  // target height map, R32F metres
uniform sampler2D u_tool;    // pass 3: (back depth, coverage, -, front depth), metres
// u_advance (how far the tool was advanced along u_forward): the job's entry (job.glsl).

layout(location = 0) out vec4 f_address;  // (u, v, view depth, bumped view depth), metres

// Whether a surface at this bumped depth lies behind the tool: in front of the tool's nearest face
// at this pixel at first touch (pass 3's front less the advance). An open tool, such as a plate
// seen from below, may show no front face: then no test.
bool behind_tool(float bumped) {
    vec4 tool = texelFetch(u_tool, ivec2(gl_FragCoord.xy), 0);
    return tool.a < 0.5 * NO_FRONT && bumped < tool.a - u_advance - FRONT_TOLERANCE;
}

#if QUAD  // a built-in sphere or capsule as one quad: where the pixel's view line enters the exact solid
#include "quad_uv.glsl"
// u_near_clip: surface.vert's clip distance, done here (job.glsl).

void main() {
    ivec2 size = textureSize(u_height, 0);
    vec3 line = camera_line(gl_FragCoord.xy);
    float depth = swept_view_depth(line, -1e30, false, u_eye, u_forward);
    if (depth < u_near_clip) discard;  // missed, or nearer than the slab
    vec3 p = line + u_forward * depth, n;
    swept_snap(p, n);
    vec2 uv = quad_uv(p);
    float bumped = bumped_depth(depth, texelFetch(u_height, texel_of(uv, size), 0).r, n, u_forward);
    if (behind_tool(bumped)) discard;
    gl_FragDepth = window_depth(bumped);
    f_address = vec4(uv, depth, bumped);
}
#else
in vec2 v_uv;
in float v_depth;    // view depth of the mesh surface, metres
in vec3 v_normal;
in vec3 v_world;

void main() {
    ivec2 size = textureSize(u_height, 0);
    float h = texelFetch(u_height, texel_of(v_uv, size), 0).r;
    float depth = v_depth;
    vec3 n = normalize(v_normal);
#if SWEPT  // a built-in sphere or capsule: its smooth surface, not the facet
    {
        vec3 line = camera_line(gl_FragCoord.xy);  // exact: the same bits in any tile
        depth = swept_view_depth(line, depth, false, u_eye, u_forward);
        vec3 p = line + u_forward * depth;
        swept_snap(p, n);
    }
#endif
    float bumped = bumped_depth(depth, h, n, u_forward);
    if (behind_tool(bumped)) discard;
    gl_FragDepth = window_depth(bumped);
    f_address = vec4(v_uv, depth, bumped);
}
#endif
