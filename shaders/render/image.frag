#version 330 core
// An image in a screen rectangle (the debug views' legends), alpha-blended over the frame.
uniform sampler2D u_texture;  // RGBA8, row 0 at the bottom
uniform vec4 u_rect;          // x, y, width, height in pixels
out vec4 f_colour;
void main() {
    f_colour = texture(u_texture, (gl_FragCoord.xy - u_rect.xy) / u_rect.zw);
}
