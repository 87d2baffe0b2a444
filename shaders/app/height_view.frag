#version 330 core
// The panel's view of one body's height map, coloured as the height view colours a surface
// (depth_ramp.glsl, the legend's scale). Each output pixel shows the deepest texel of the block
// of the map it covers, so a dent narrower than a pixel still shows.
#include "render/depth_ramp.glsl"
uniform sampler2D u_height;  // R32F, metres along the normal: 0 untouched, < 0 dented
uniform float u_full_scale;  // metres of depth at the ramp's top
uniform int u_block;         // map texels per output pixel along each axis (1 .. 16)
out vec4 f_colour;
void main() {
    ivec2 first = ivec2(gl_FragCoord.xy) * u_block;
    ivec2 last = textureSize(u_height, 0) - 1;
    float lowest = 0.0;
    for (int y = 0; y < u_block; ++y) {
        for (int x = 0; x < u_block; ++x) {
            lowest = min(lowest, texelFetch(u_height, min(first + ivec2(x, y), last), 0).r);
        }
    }
    f_colour = vec4(depth_ramp(-lowest / u_full_scale), 1.0);
}
