#version 330 core
// Sky gradient behind everything, from the view direction through each pixel.
#include "../include/srgb.glsl"
uniform mat4 u_inverse_view_proj;  // world from clip
uniform vec2 u_viewport;           // pixels
out vec4 f_colour;
void main() {
    vec2 ndc = gl_FragCoord.xy / u_viewport * 2.0 - 1.0;
    vec4 far = u_inverse_view_proj * vec4(ndc, 1.0, 1.0);
    vec4 near = u_inverse_view_proj * vec4(ndc, -1.0, 1.0);
    vec3 dir = normalize(far.xyz / far.w - near.xyz / near.w);
    float t = clamp(dir.y * 1.5 + 0.2, 0.0, 1.0);
    vec3 colour = mix(vec3(0.75, 0.78, 0.8), vec3(0.25, 0.45, 0.75), t);
    f_colour = vec4(linear_to_srgb(colour), 1.0);
}
