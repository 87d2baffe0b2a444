#version 330 core
// The environment behind everything: the same light the bodies reflect (the baked radiance atlas,
// its sharp row), tone mapped.
#include "../include/equirect.glsl"
#include "../include/tonemap.glsl"
uniform mat4 u_inverse_view_proj;  // world from clip
uniform vec2 u_viewport;           // pixels
uniform sampler2D u_radiance;      // equirect atlas; row 0 of u_levels is the unfiltered light
uniform int u_levels;
uniform float u_exposure;
uniform float u_ambient;           // the environment's strength, as for the bodies
out vec4 f_colour;
void main() {
    vec2 ndc = gl_FragCoord.xy / u_viewport * 2.0 - 1.0;
    vec4 far = u_inverse_view_proj * vec4(ndc, 1.0, 1.0);
    vec4 near = u_inverse_view_proj * vec4(ndc, -1.0, 1.0);
    vec3 dir = normalize(far.xyz / far.w - near.xyz / near.w);
    vec2 uv = equirect_uv(dir);
    float half_texel = 0.5 / float(textureSize(u_radiance, 0).y);
    uv.y = clamp(uv.y / float(u_levels), half_texel, 1.0 / float(u_levels) - half_texel);
    f_colour = vec4(tonemap(texture(u_radiance, uv).rgb * u_ambient, u_exposure), 1.0);
}
