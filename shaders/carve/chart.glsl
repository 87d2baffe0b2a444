// The chart mask (R8UI, one byte a texel, made once per map by util/chart_bits.frag): the bit
// CHART_SELF is set where the texel lies inside a UV chart, CHART_LEFT, CHART_RIGHT, CHART_DOWN and
// CHART_UP where its neighbour at -u, +u, -v, +v does (and lies inside the map); the values are
// defines from constants.py. One fetch answers what central differences need at a texel.
#include "../include/texel.glsl"

uniform usampler2D u_mask;

uint chart_bits(ivec2 t) {
    return texelFetch(u_mask, t, 0).r;
}

// Whether texel t (anywhere, inside the map or not) lies inside a chart.
bool in_chart(ivec2 t, ivec2 size) {
    return in_map(t, size) && (chart_bits(t) & CHART_SELF) != 0u;
}
