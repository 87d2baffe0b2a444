#version 330 core
// ---- Pass 4: gather into the height map ---------------------------------------------------------
// One fragment per texel of the target's surface map inside the footprint (texel.vert, .geom). The
// texel's own centre on the surface (world point and normal; a built-in sphere or capsule moves it
// along its normal onto its smooth surface) is projected into the collision
// camera, checked against the address map (is this the surface the camera saw there?) and compared
// with the tool's deepest point along the view (pass 3, bilinear between camera pixels). The new
// height moves the texel's point along its normal to the tool:
//     h = -(tool depth - surface depth) / max(cos(normal, -forward), MIN_COS)     (metres)
// It does not depend on the old height, so an identical press writes identical values; blending
// MIN keeps the deeper of old and new (dents only deepen, presses are idempotent).
#include "camera.glsl"
#include "texel.glsl"
#include "swept.glsl"
#include "chart.glsl"

uniform sampler2D u_address;     // pass 2: (u, v, view depth, bumped view depth)
uniform sampler2D u_tool_depth;  // pass 3: (the tool's bumped view depth m, coverage), LINEAR
uniform float u_min_height;      // -max_dent_depth of the target, metres
uniform float u_ceiling;         // no texel of the target is higher than this, metres
uniform float u_pixel_diagonal;  // a camera pixel's diagonal, metres

out float f_height;

bool tool_sample(ivec2 pixel, out float depth) {
    depth = NO_TOOL;
    if (!inside_camera(pixel)) return false;
    vec2 tool = texelFetch(u_tool_depth, pixel, 0).rg;
    depth = tool.r;
    return tool.g > 0.5;
}

// The tool's depth at continuous pixel position p: bilinear, by the sampler, where the four pixels
// around p all see the tool (their filtered coverage is 1; pixels without the tool hold 0 in both
// channels, so depth / coverage is the blend of those that have it), else the pixel that holds p.
bool tool_depth_at(vec2 p, out float depth) {
    ivec2 base = ivec2(floor(p));
    if (all(greaterThanEqual(base, ivec2(0))) && all(lessThan(base + 1, u_resolution))) {
        vec2 tool = texture(u_tool_depth, (p + 0.5) / vec2(textureSize(u_tool_depth, 0))).rg;
        if (tool.g >= FULL_COVERAGE) {
            depth = tool.r / tool.g;
            return true;
        }
    }
    return tool_sample(ivec2(floor(p + 0.5)), depth);
}

void main() {
#if GUTTER
    if ((chart_bits(ivec2(gl_FragCoord.xy)) & CHART_SELF) != 0u) discard;  // GUTTER 0 has it
#endif
    vec3 world, n;
    ivec2 source;
    if (!texel_surface(world, n, source)) discard;
#if SWEPT
    swept_snap(world, n);  // a built-in sphere or capsule: its smooth surface
#endif
    float cos_view = -dot(n, u_forward);
    if (!(cos_view > 0.0)) discard;  // faces away from the camera
    vec3 rel = world - u_eye;
    float depth = dot(rel, u_forward);  // view depth of the texel's point, metres
    vec2 p = camera_pixel(rel);
    ivec2 pixel = ivec2(floor(p + 0.5));
    if (!inside_camera(pixel)) discard;
    vec4 address = texelFetch(u_address, pixel, 0);
    if (address.x <= NO_SURFACE) discard;
    // Hidden: the surface in front at that pixel is elsewhere (beyond the slope over a pixel).
    float slope = sqrt(max(1.0 - cos_view * cos_view, 0.0)) / max(cos_view, MIN_COS);
    if (abs(address.z - depth) > u_pixel_diagonal * (1.0 + slope)) discard;
    float tool;
    if (!tool_depth_at(p, tool)) discard;
    float h = -(tool - depth) / max(cos_view, MIN_COS);
    if (!(h < u_ceiling)) discard;  // the tool does not reach this texel
    f_height = max(h, u_min_height);
}
