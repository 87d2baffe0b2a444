#version 330 core
// The low and medium presets shade fewer pixels: the frame, rendered at a fraction of the output
// size, is stretched onto the output with bilinear filtering (sRGB bytes in, bytes out).
uniform sampler2D u_frame;
uniform vec2 u_viewport;  // output pixels
out vec4 f_colour;
void main() { f_colour = texture(u_frame, gl_FragCoord.xy / u_viewport); }
