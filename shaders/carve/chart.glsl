// The chart mask (R8UI, one byte a texel, made once per map by util/chart_bits.frag): bit 0 is set
// where the texel lies inside a UV chart, bits 1 to 4 where its neighbour at -u, +u, -v, +v does
// (and lies inside the map). One fetch answers what central differences need at a texel.
uniform usampler2D u_mask;

const uint CHART_SELF = 1u;
const uint CHART_LEFT = 2u;   // -u
const uint CHART_RIGHT = 4u;  // +u
const uint CHART_DOWN = 8u;   // -v
const uint CHART_UP = 16u;    // +v

uint chart_bits(ivec2 t) {
    return texelFetch(u_mask, t, 0).r;
}

// Whether texel t (anywhere, inside the map or not) lies inside a chart.
bool in_chart(ivec2 t, ivec2 size) {
    if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, size))) return false;
    return (chart_bits(t) & CHART_SELF) != 0u;
}
