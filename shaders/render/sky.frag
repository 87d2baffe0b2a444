#version 330 core
// Sky gradient behind everything, from the view direction through each pixel. The gradient is
// authored in sRGB, so no per-pixel conversion is needed.
uniform mat4 u_inverse_view_proj;  // world from clip
uniform vec2 u_viewport;           // pixels
out vec4 f_colour;
void main() {
    vec2 ndc = gl_FragCoord.xy / u_viewport * 2.0 - 1.0;
    vec4 far = u_inverse_view_proj * vec4(ndc, 1.0, 1.0);
    vec4 near = u_inverse_view_proj * vec4(ndc, -1.0, 1.0);
    vec3 dir = normalize(far.xyz / far.w - near.xyz / near.w);
    float t = clamp(dir.y * 1.5 + 0.2, 0.0, 1.0);
    f_colour = vec4(mix(vec3(0.89, 0.90, 0.91), vec3(0.54, 0.70, 0.88), t), 1.0);
}
