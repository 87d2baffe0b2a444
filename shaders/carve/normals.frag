#version 330 core
// ---- Pass 5: normal rebuild ---------------------------------------------------------------------
// The tangent-space normal of each texel of the footprint (texel.vert, .geom; slab grown by two
// texels) from central differences of the height map, one-sided at chart borders so gutters never
// leak into a chart. Differences per texel become slopes through the texel's metric (texel.glsl).
// Gutter texels take the normal of the chart texel nearest to them on their triangle.
#include "../include/common.glsl"
// Drawn instanced (texel.vert, texel.geom, util/rect.vert): the entry from the stage before.
flat in int v_job;
#define JOB v_job
#include "camera.glsl"
#include "chart.glsl"
#include "texel.glsl"

uniform sampler2D u_height;  // R32F metres

out vec4 f_normal;

// Height change per texel step along `step` (metres), one-sided at chart borders: `lo_in`, `hi_in`
// say whether t - step and t + step lie inside a chart.
float difference(ivec2 t, ivec2 step, bool lo_in, bool hi_in) {
    ivec2 lo = lo_in ? t - step : t;
    ivec2 hi = hi_in ? t + step : t;
    float span = float(lo_in) + float(hi_in);
    if (span < 1.0) return 0.0;
    return (texelFetch(u_height, hi, 0).r - texelFetch(u_height, lo, 0).r) / span;
}

void main() {
#if RECT
    if (!rect_triangle()) discard;  // no chart texel (the gutter draw has it)
#endif
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
    uint bits = chart_bits(source);
    bool left = (bits & CHART_LEFT) != 0u, right = (bits & CHART_RIGHT) != 0u;
    bool down = (bits & CHART_DOWN) != 0u, up = (bits & CHART_UP) != 0u;
    float du = difference(source, ivec2(1, 0), left, right);
    float dv = difference(source, ivec2(0, 1), down, up);
    float grad_t = du / metric.x;                          // dh/ds along T
    float grad_b = (dv - grad_t * metric.y) / metric.z;    // dh/ds along B
    f_normal = vec4(encode_normal(normalize(vec3(-grad_t, -grad_b, 1.0))), 1.0);
}
