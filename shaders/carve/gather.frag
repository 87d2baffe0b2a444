#version 330 core
// ---- Pass 4: gather into the height map ---------------------------------------------------------
// One fragment per texel of the target's surface map inside the footprint (texel.vert, .geom). The
// texel's own centre on the surface (world point and normal; a built-in sphere or capsule moves it
// along its normal onto its smooth surface) is projected into the collision
// camera, checked against the address map (is this the surface the camera saw there?) and compared
// with the tool's deepest point along the view (pass 3, bilinear between camera pixels): that is
// the back of the solid the tool sweeps from first touch. The new height moves the texel's point
// inwards along its normal until it leaves that solid: the a >= 0 (metres) with
//     a = (tool depth at the pixel of (point - a normal) - surface depth) / max(cos, MIN_COS)
// (cos = cos(normal, -forward)), found by fixed-point steps from the pixel of the point itself (one
// step, exact, when the normal is the press direction). h = -a. It does not depend on the old
// height, so an identical press writes identical values; blending MIN keeps the deeper of old and
// new (dents only deepen, presses are idempotent).
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

// How far beyond the swept solid's back (metres along the view) the texel's point lies once moved
// `a` metres inwards along its normal: < 0 inside. False where its pixel is off the tool (out).
bool beyond(vec3 rel, vec3 n, float depth, float stretch, float a, out float f) {
    float back;
    f = 0.0;
    if (!tool_depth_at(camera_pixel(rel - n * a), back)) return false;
    f = depth + a / stretch - back;
    return true;
}

// The inward distance a (metres) at which the texel's point leaves the swept solid, from the
// first guess `a0` (the view-line estimate), by false position with the Illinois step between a
// point inside (lo) and one outside (hi), at most EXIT_STEPS look-ups after the bracket.
float normal_exit(vec3 rel, vec3 n, float depth, float stretch, float a0) {
    float lo = 0.0, f_lo = -a0 / stretch;  // the point itself: inside by the tool's depth
    float hi = a0, f_hi;
    bool on_hi = beyond(rel, n, depth, stretch, hi, f_hi);
    for (int k = 0; k < 4 && on_hi && f_hi < 0.0; ++k) {  // still inside: look further in
        lo = hi;
        f_lo = f_hi;
        hi *= 2.0;
        on_hi = beyond(rel, n, depth, stretch, hi, f_hi);
    }
    if (on_hi && f_hi < 0.0) return hi;
    float a = hi;
    for (int k = 0; k < EXIT_STEPS; ++k) {
        a = on_hi ? (lo * f_hi - hi * f_lo) / (f_hi - f_lo) : 0.5 * (lo + hi);
        float f;
        bool on = beyond(rel, n, depth, stretch, a, f);
        if (on && abs(f) <= EXIT_SETTLED_METRES) break;
        if (on && f < 0.0) {
            lo = a;
            f_lo = f;
            f_hi *= 0.5;
        } else {
            hi = a;
            f_hi = f;
            on_hi = on;
            f_lo *= 0.5;
        }
    }
    return a;
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
    float stretch = 1.0 / max(cos_view, MIN_COS);
    float inward = (tool - depth) * stretch;
    // Along the normal, not the view: the moved point sees another pixel (none when n = -forward).
    if (inward > 0.0 && cos_view < 1.0 - 1e-6) inward = normal_exit(rel, n, depth, stretch, inward);
    float h = -inward;
    if (!(h < u_ceiling)) discard;  // the tool does not reach this texel
    f_height = max(h, u_min_height);
}
