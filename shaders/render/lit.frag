#version 330 core
// Blinn-Phong with the body's rebuilt tangent-space normal map, a PCF-filtered directional
// shadow, optional parallax occlusion mapping from the height map, and debug views.
// Compile-time variants (the renderer sets them): PARALLAX 0/1, VIEW 0 shaded / 1 height / 2 normal.
#ifndef PARALLAX
#define PARALLAX 0
#endif
#ifndef VIEW
#define VIEW 0
#endif
#include "frame.glsl"
#include "../include/common.glsl"
#include "../include/srgb.glsl"

uniform sampler2D u_normal_map;   // RGBA8 tangent-space normal
uniform sampler2D u_height_map;   // R32F metres (negative = dent)
uniform sampler2DShadow u_shadow_map;  // light depth in [0, 1], compared in hardware
uniform vec3 u_albedo;            // linear RGB
uniform float u_specular;         // specular strength
uniform float u_shininess;        // Blinn-Phong exponent
uniform bool u_checker;           // the ground's checker pattern
uniform vec2 u_uv_per_metre;      // texture-space length of one metre along +u and +v
uniform float u_max_depth;        // deepest possible dent, metres (parallax search range)

in vec3 v_world;
in vec2 v_uv;
in vec3 v_normal;
in vec3 v_tangent;
in vec3 v_bitangent;
in vec4 v_light_clip;

out vec4 f_colour;

// Height below the mesh surface in metres at uv (positive = deeper).
float depth_at(vec2 uv) { return -texture(u_height_map, uv).r; }

// March the view ray (tangent space, metres) into the height field; return the uv it meets.
vec2 parallax_uv(vec2 uv, vec3 view_ts) {
    if (u_max_depth <= 0.0 || view_ts.z <= 0.05) return uv;
    const int STEPS = 24;
    float layer = u_max_depth / float(STEPS);
    vec2 step_uv = -view_ts.xy / view_ts.z * layer * u_uv_per_metre;
    float ray = 0.0;
    vec2 cur = uv;
    float surf = depth_at(cur);
    for (int i = 0; i < STEPS && ray < surf; ++i) {
        cur += step_uv;
        ray += layer;
        surf = depth_at(cur);
    }
    // Refine between the last two samples.
    vec2 prev = cur - step_uv;
    float after = surf - ray;
    float before = depth_at(prev) - (ray - layer);
    float t = after / max(after - before, 1e-9);
    return mix(cur, prev, clamp(t, 0.0, 1.0));
}

float shadow_factor(vec3 n) {
    vec3 p = v_light_clip.xyz / v_light_clip.w * 0.5 + 0.5;
    if (any(lessThan(p, vec3(0.0))) || any(greaterThan(p, vec3(1.0)))) return 1.0;
    float bias = 0.0015 + 0.002 * (1.0 - max(dot(n, -u_light_dir), 0.0));
    // Four bilinear comparison taps: a 3 x 3 texel percentage-closer filter.
    vec2 texel = 1.0 / vec2(textureSize(u_shadow_map, 0));
    float lit = 0.0;
    for (int i = 0; i < 4; ++i) {
        vec2 offset = (vec2(i & 1, i >> 1) - 0.5) * texel;
        lit += texture(u_shadow_map, vec3(p.xy + offset, p.z - bias));
    }
    return lit * 0.25;
}

void main() {
    mat3 tbn = mat3(normalize(v_tangent), normalize(v_bitangent), normalize(v_normal));
    vec3 view = normalize(u_camera_pos - v_world);
#if PARALLAX
    vec2 uv = parallax_uv(v_uv, transpose(tbn) * view);
#else
    vec2 uv = v_uv;
#endif
    vec3 n = normalize(tbn * decode_normal(texture(u_normal_map, uv).rgb));
#if VIEW == 1
    float d = clamp(depth_at(uv) / max(u_max_depth, 1e-6), 0.0, 1.0);
    f_colour = vec4(linear_to_srgb(mix(vec3(0.9), vec3(0.9, 0.1, 0.05), sqrt(d))), 1.0);
    return;
#elif VIEW == 2
    f_colour = vec4(texture(u_normal_map, uv).rgb, 1.0);
    return;
#endif
    vec3 albedo = u_albedo;
    if (u_checker) {
        vec2 cell = floor(v_world.xz / 0.25);
        albedo *= mod(cell.x + cell.y, 2.0) < 0.5 ? 1.0 : 0.8;
    }
    vec3 l = -u_light_dir;
    float diffuse = max(dot(n, l), 0.0);
    vec3 h = normalize(l + view);
    float spec = diffuse > 0.0 ? u_specular * pow(max(dot(n, h), 0.0), u_shininess) : 0.0;
    float shadow = shadow_factor(normalize(v_normal));
    vec3 sky = mix(vec3(0.35, 0.33, 0.3), vec3(0.55, 0.65, 0.8), n.y * 0.5 + 0.5);
    vec3 colour = albedo * (u_ambient * sky) + u_light_colour * shadow * (albedo * diffuse + spec);
    f_colour = vec4(linear_to_srgb(colour / (1.0 + colour * 0.15)), 1.0);
}
