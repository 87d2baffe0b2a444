#version 330 core
// The chart mask's bits (carve/chart.glsl, values from constants.py) from the charts' coverage:
// whether this texel and each of its four neighbours lie inside a chart. Drawn once over the whole
// map when it is made.
#include "../include/texel.glsl"

uniform sampler2D u_coverage;  // R8: 1 where a chart's triangles cover the texel centre

out uint f_bits;

bool covered(ivec2 t, ivec2 size) {
    return in_map(t, size) && texelFetch(u_coverage, t, 0).r >= 0.5;
}

void main() {
    ivec2 size = textureSize(u_coverage, 0);
    ivec2 t = ivec2(gl_FragCoord.xy);
    f_bits = (covered(t, size) ? CHART_SELF : 0u)
        | (covered(t - ivec2(1, 0), size) ? CHART_LEFT : 0u)
        | (covered(t + ivec2(1, 0), size) ? CHART_RIGHT : 0u)
        | (covered(t - ivec2(0, 1), size) ? CHART_DOWN : 0u)
        | (covered(t + ivec2(0, 1), size) ? CHART_UP : 0u);
}
