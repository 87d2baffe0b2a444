#version 330 core
// ---- Pass 4: scatter into the height map ------------------------------------------------------------
// Blending is MIN: many pixels on one texel resolve to the deepest; dents only deepen; a repeated
// press writes the same value (idempotent). Gutter texels next to the chart copy the border texel.

uniform sampler2D u_mask;

flat in float v_height;
flat in ivec2 v_texel;

out float f_height;

void main() {
    ivec2 t = ivec2(gl_FragCoord.xy);
    if (t != v_texel && texelFetch(u_mask, t, 0).r >= 0.5) discard;
    f_height = v_height;
}
