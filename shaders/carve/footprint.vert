#version 330 core
// Passes 4 and 5: one point per collision-camera pixel (vertex pulling, no vertex arrays). A pixel
// whose pass-3 height is set lands on its texel of the target's surface map.
#include "../include/texel.glsl"

const float NO_CHANGE = 1.0e30;  // pass-3 clear value: nothing reached this pixel

uniform sampler2D u_address;     // pass 2: (u, v, height, cos)
uniform sampler2D u_new_height;  // pass 3: new height, metres, or NO_CHANGE
uniform sampler2D u_mask;        // target chart mask: 1 inside a UV chart, 0 in gutters
uniform int u_width;             // collision-camera pixels per row
uniform float u_point_size;      // texels covered around the dented texel (1 or 3)

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

void main() {
    ivec2 pixel = ivec2(gl_VertexID % u_width, gl_VertexID / u_width);
    float h = texelFetch(u_new_height, pixel, 0).r;
    vec2 uv = texelFetch(u_address, pixel, 0).xy;
    ivec2 size = textureSize(u_mask, 0);
    v_height = h;
    v_texel = texel_of(uv, size);
    if (!(h < 0.5 * NO_CHANGE) || isinf(h) || uv.x < 0.0) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the clip volume: dropped
        gl_PointSize = 1.0;
        return;
    }
    // On a chart border the point also covers the gutter texels beside it.
    gl_PointSize = max(u_point_size, at_chart_border(v_texel, size) ? 3.0 : 1.0);
    gl_Position = vec4(texel_ndc(v_texel, size), 0.0, 1.0);
}
