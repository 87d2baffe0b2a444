#version 330 core
// The environment behind everything (the same procedural light the bodies reflect), tone mapped.
#include "../include/tonemap.glsl"
#include "environment.glsl"
uniform mat4 u_inverse_view_proj;  // world from clip
uniform vec2 u_viewport;           // pixels
uniform float u_exposure;
uniform float u_ambient;           // the environment's strength, as for the bodies
out vec4 f_colour;
void main() {
    vec2 ndc = gl_FragCoord.xy / u_viewport * 2.0 - 1.0;
    vec4 far = u_inverse_view_proj * vec4(ndc, 1.0, 1.0);
    vec4 near = u_inverse_view_proj * vec4(ndc, -1.0, 1.0);
    vec3 dir = normalize(far.xyz / far.w - near.xyz / near.w);
    f_colour = vec4(tonemap(environment(dir) * u_ambient, u_exposure), 1.0);
}
