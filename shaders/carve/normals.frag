#version 330 core
// ---- Pass 5: normal rebuild ---------------------------------------------------------------------
// The tangent-space normal of each texel of the footprint (texel.vert, .geom; slab grown by two
// texels) from central differences of the height map, one-sided at chart borders so gutters never
// leak into a chart. Differences per texel become slopes through the texel's metric (texel.glsl).
// Gutter texels take the normal of the chart texel nearest to them on their triangle.
#include "../include/common.glsl"
#include "texel.glsl"

uniform sampler2D u_height;  // R32F metres
uniform sampler2D u_mask;    // 1 inside a UV chart

out vec4 f_normal;

bool in_chart(ivec2 t, ivec2 size) {
    if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, size))) return false;
    return texelFetch(u_mask, t, 0).r >= 0.5;
}

// Height change per texel step along `step` (metres), one-sided at chart borders.
float difference(ivec2 t, ivec2 step, ivec2 size) {
    ivec2 lo = t - step, hi = t + step;
    float span = 2.0;
    if (!in_chart(lo, size)) { lo = t; span -= 1.0; }
    if (!in_chart(hi, size)) { hi = t; span -= 1.0; }
    if (span < 1.0) return 0.0;
    return (texelFetch(u_height, hi, 0).r - texelFetch(u_height, lo, 0).r) / span;
}

void main() {
    vec3 metric = texel_metric();
    ivec2 size = textureSize(u_height, 0);
    ivec2 t = ivec2(gl_FragCoord.xy);
#if GUTTER
    if (in_chart(t, size)) discard;  // GUTTER 0 has it
#endif
    vec3 world, n;
    ivec2 source;
    if (!texel_surface(world, n, source)) discard;
#if GUTTER
    if (!in_chart(source, size)) {  // the nearest point lies in a texel of the gutter too
        float best = 1e30;
        vec2 near = vec2(source) + 0.5;
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                ivec2 q = t + ivec2(dx, dy);
                float d = distance(vec2(q) + 0.5, near);
                if (in_chart(q, size) && d < best) { best = d; source = q; }
            }
        if (best > 1e29) discard;
    }
#endif
    float du = difference(source, ivec2(1, 0), size);
    float dv = difference(source, ivec2(0, 1), size);
    float grad_t = du / metric.x;                          // dh/ds along T
    float grad_b = (dv - grad_t * metric.y) / metric.z;    // dh/ds along B
    f_normal = vec4(encode_normal(normalize(vec3(-grad_t, -grad_b, 1.0))), 1.0);
}
