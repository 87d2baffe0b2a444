#version 330 core
// ---- Pass 5: normal rebuild -------------------------------------------------------------------------
// The tangent-space normal of each covered texel from central differences of the height map (metres
// per texel along +u and +v); one-sided at chart borders so gutters never leak into a chart. Gutter
// texels take the normal of the chart texel that the point came from.
#include "../include/common.glsl"

uniform sampler2D u_height;     // R32F metres
uniform sampler2D u_mask;       // 1 inside a UV chart
uniform vec2 u_texel_metres;    // surface length of one texel along +u and +v, metres
uniform bool u_whole_map;       // true when called over the full map (creation, import)

flat in ivec2 v_texel;

out vec4 f_normal;

bool in_chart(ivec2 t, ivec2 size) {
    if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, size))) return false;
    return texelFetch(u_mask, t, 0).r >= 0.5;
}

float slope(ivec2 t, ivec2 step, float texel_metres, ivec2 size) {
    ivec2 lo = t - step, hi = t + step;
    float span = 2.0;
    if (!in_chart(lo, size)) { lo = t; span -= 1.0; }
    if (!in_chart(hi, size)) { hi = t; span -= 1.0; }
    if (span < 1.0) return 0.0;
    float dh = texelFetch(u_height, hi, 0).r - texelFetch(u_height, lo, 0).r;
    return dh / (span * texel_metres);
}

void main() {
    ivec2 size = textureSize(u_height, 0);
    ivec2 t = ivec2(gl_FragCoord.xy);
    if (!in_chart(t, size)) {
        if (u_whole_map) { f_normal = vec4(encode_normal(vec3(0.0, 0.0, 1.0)), 1.0); return; }
        t = v_texel;
    }
    float du = slope(t, ivec2(1, 0), u_texel_metres.x, size);
    float dv = slope(t, ivec2(0, 1), u_texel_metres.y, size);
    f_normal = vec4(encode_normal(normalize(vec3(-du, -dv, 1.0))), 1.0);
}
