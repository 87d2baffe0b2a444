#version 330 core
// A debug texture in a screen rectangle: the last hit's address map, (u, v) as red and green;
// pixels with no surface are dark blue, as in the paper.
uniform sampler2D u_texture;
uniform vec4 u_rect;        // x, y, width, height in pixels
uniform vec2 u_extent;      // the part of u_texture in use, in texels
out vec4 f_colour;
void main() {
    vec2 t = (gl_FragCoord.xy - u_rect.xy) / u_rect.zw;
    vec4 a = texelFetch(u_texture, ivec2(t * u_extent), 0);
    f_colour = a.x < 0.0 ? vec4(0.05, 0.05, 0.3, 1.0) : vec4(fract(a.x * 8.0), fract(a.y * 8.0), 0.0, 1.0);
}
