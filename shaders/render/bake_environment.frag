#version 330 core
// Start-up bake of the environment into an equirectangular atlas of LEVELS rows, each the
// radiance prefiltered with the GGX lobe of roughness level / (LEVELS - 1) (split-sum, N = V = R,
// importance sampled with a Hammersley set), and, with IRRADIANCE, the cosine-weighted irradiance
// divided by pi (a Lambert surface's outgoing radiance for albedo 1).
#include "../include/equirect.glsl"
#include "environment.glsl"

uniform ivec2 u_level_size;  // texels of one level
uniform int u_levels;
uniform int u_samples;
out vec4 f_colour;

vec2 hammersley(int i, int n) {
    uint bits = uint(i);
    bits = (bits << 16u) | (bits >> 16u);
    bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
    bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
    bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
    bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
    return vec2(float(i) / float(n), float(bits) * 2.3283064365386963e-10);
}

mat3 frame_around(vec3 n) {
    vec3 up = abs(n.y) < 0.999 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
    vec3 t = normalize(cross(up, n));
    return mat3(t, cross(n, t), n);
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    int level = p.y / u_level_size.y;
    vec2 uv = (vec2(p.x, p.y - level * u_level_size.y) + 0.5) / vec2(u_level_size);
    vec3 n = equirect_dir(uv);
    mat3 basis = frame_around(n);
    vec3 sum = vec3(0.0);
    float weight = 0.0;
#if IRRADIANCE
    for (int i = 0; i < u_samples; ++i) {  // cosine-weighted hemisphere
        vec2 xi = hammersley(i, u_samples);
        float r = sqrt(xi.x), phi = 2.0 * PI * xi.y;
        vec3 l = basis * vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - xi.x, 0.0)));
        sum += environment(l);
        weight += 1.0;
    }
#else
    float roughness = float(level) / float(max(u_levels - 1, 1));
    float a = max(roughness * roughness, 1e-3);
    if (roughness == 0.0) {
        sum = environment(n);
        weight = 1.0;
    }
    for (int i = 0; roughness > 0.0 && i < u_samples; ++i) {  // GGX half vectors around n
        vec2 xi = hammersley(i, u_samples);
        float cos_h = sqrt((1.0 - xi.y) / (1.0 + (a * a - 1.0) * xi.y));
        float sin_h = sqrt(1.0 - cos_h * cos_h), phi = 2.0 * PI * xi.x;
        vec3 h = basis * vec3(sin_h * cos(phi), sin_h * sin(phi), cos_h);
        vec3 l = 2.0 * dot(n, h) * h - n;
        float nl = dot(n, l);
        if (nl > 0.0) {
            sum += environment(l) * nl;
            weight += nl;
        }
    }
#endif
    f_colour = vec4(sum / max(weight, 1e-6), 1.0);
}
