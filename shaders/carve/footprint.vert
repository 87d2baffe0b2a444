#version 330 core
// Passes 4 and 5: one point per collision-camera pixel (vertex pulling, no vertex arrays). A pixel
// whose pass-3 height is set lands on its texel of the target's surface map.
#include "../include/texel.glsl"

// TO_CENTRE 1: the scatter for curved charts, where several camera pixels share a texel.
#ifndef TO_CENTRE
#define TO_CENTRE 0
#endif

const float NO_CHANGE = 1.0e30;  // pass-3 clear value: nothing reached this pixel

uniform sampler2D u_address;     // pass 2: (u, v, height, cos)
uniform sampler2D u_new_height;  // pass 3: new height, metres, or NO_CHANGE
uniform sampler2D u_mask;        // target chart mask: 1 inside a UV chart, 0 in gutters
uniform int u_width;             // collision-camera pixels per row
uniform int u_rows;              // collision-camera rows
uniform float u_point_size;      // texels covered around the dented texel (1 or 3)
uniform float u_min_height;      // -max_dent_depth of the target, metres

flat out float v_height;
flat out ivec2 v_texel;

bool at_chart_border(ivec2 t, ivec2 size) {
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = t + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
            if (texelFetch(u_mask, q, 0).r < 0.5) return true;
        }
    return false;
}

#if TO_CENTRE
// A neighbouring camera pixel's (uv, new height), if it is dented and on the same chart.
bool sample_at(ivec2 q, vec2 uv, ivec2 size, out vec3 s) {
    if (q.x < 0 || q.y < 0 || q.x >= u_width || q.y >= u_rows) return false;
    float h = texelFetch(u_new_height, q, 0).r;
    vec2 quv = texelFetch(u_address, q, 0).xy;
    if (!(h < 0.5 * NO_CHANGE) || quv.x < 0.0) return false;
    if (any(greaterThan(abs(quv - uv) * vec2(size), vec2(2.0)))) return false;  // another chart
    s = vec3(quv, h);
    return true;
}

// Finite difference along one camera axis: (d uv, d h) per pixel; false if no neighbour is usable.
bool axis_step(ivec2 p, ivec2 step, vec3 centre, ivec2 size, out vec3 diff) {
    vec3 lo, hi;
    bool has_lo = sample_at(p - step, centre.xy, size, lo);
    bool has_hi = sample_at(p + step, centre.xy, size, hi);
    if (has_lo && has_hi) { diff = (hi - lo) * 0.5; return true; }
    if (has_hi) { diff = hi - centre; return true; }
    if (has_lo) { diff = centre - lo; return true; }
    return false;
}

// Several camera pixels fall in one texel of a curved chart; MIN would keep the deepest of them, a
// bias of the slope times up to half a texel. Moving every sample to the texel centre along the
// local gradient (d h / d uv from neighbouring pixels) makes them all estimate the same value.
float height_at_texel_centre(ivec2 p, vec2 uv, float h, ivec2 size) {
    vec2 offset = (vec2(texel_of(uv, size)) + 0.5) / vec2(size) - uv;
    if (all(lessThan(abs(offset) * vec2(size), vec2(1e-3)))) return h;  // already at the centre
    vec3 centre = vec3(uv, h), dx, dy;
    if (!axis_step(p, ivec2(1, 0), centre, size, dx) || !axis_step(p, ivec2(0, 1), centre, size, dy))
        return h;  // the rim of the dent: no gradient, keep the sample
    mat2 jacobian = mat2(dx.xy, dy.xy);  // d uv / d pixel, columns x and y
    float det = determinant(jacobian);
    if (abs(det) < 1e-12) return h;
    vec2 gradient = transpose(inverse(jacobian)) * vec2(dx.z, dy.z);  // d h / d uv
    return h + dot(gradient, offset);
}
#endif

void main() {
    ivec2 pixel = ivec2(gl_VertexID % u_width, gl_VertexID / u_width);
    float h = texelFetch(u_new_height, pixel, 0).r;
    vec2 uv = texelFetch(u_address, pixel, 0).xy;
    ivec2 size = textureSize(u_mask, 0);
    v_texel = texel_of(uv, size);
    if (!(h < 0.5 * NO_CHANGE) || isinf(h) || uv.x < 0.0) {
        v_height = h;
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the clip volume: dropped
        gl_PointSize = 1.0;
        return;
    }
#if TO_CENTRE
    v_height = max(height_at_texel_centre(pixel, uv, h, size), u_min_height);
#else
    v_height = h;
#endif
    // On a chart border the point also covers the gutter texels beside it.
    gl_PointSize = max(u_point_size, at_chart_border(v_texel, size) ? 3.0 : 1.0);
    gl_Position = vec4(texel_ndc(v_texel, size), 0.0, 1.0);
}
