#version 330 core
// Physically based shading of the bodies: metallic-roughness GGX (Cook-Torrance) for the sun,
// image-based light from the baked environment (prefiltered radiance by roughness, irradiance),
// the body's rebuilt tangent-space normal map, a PCF-filtered shadow, optional parallax occlusion
// mapping, procedural surface detail, ACES tone mapping and exact sRGB output. Debug views
// replace the shading. Compile-time variants: PARALLAX 0/1; VIEW 0 shaded / 1 height / 2 normal;
// SHADOW_TAPS 1 or 4 and SURFACE_DETAIL 0/1 (the quality preset); TEXTURED 0/1 (the mesh's own
// base-colour image); GROUND 0/1 (the checkered ground: flat, facing +Y, without maps); DISPLACE
// 0/1/2 (the surface was moved by the height map: parallax marches only what is left). They are
// compile-time because a software rasteriser runs both sides of a branch on a uniform.
#ifndef PARALLAX
#define PARALLAX 0
#endif
#ifndef VIEW
#define VIEW 0
#endif
#ifndef SHADOW_TAPS
#define SHADOW_TAPS 4
#endif
#ifndef SURFACE_DETAIL
#define SURFACE_DETAIL 1
#endif
#ifndef TEXTURED
#define TEXTURED 0
#endif
#ifndef GROUND
#define GROUND 0
#endif
#ifndef DISPLACE
#define DISPLACE 0
#endif
#include "frame.glsl"
#include "../include/common.glsl"
#include "../include/equirect.glsl"
#include "../include/tonemap.glsl"
#include "surface_detail.glsl"
#include "depth_ramp.glsl"

uniform sampler2D u_normal_map;   // RGBA8 tangent-space normal
uniform sampler2D u_height_map;   // R32F metres (negative = dent)
uniform sampler2DShadow u_shadow_map;  // light depth in [0, 1], compared in hardware
uniform sampler2D u_radiance;     // equirect atlas: u_levels rows, roughness row / (levels - 1)
uniform sampler2D u_irradiance;   // equirect, irradiance / pi
uniform int u_levels;
uniform vec3 u_base_colour;       // linear RGB
uniform float u_metalness;        // 0 dielectric .. 1 metal
uniform float u_roughness;        // perceptual; GGX alpha = roughness^2
uniform float u_coat_thickness;   // metres of paint (0: none); deeper dents show the material
uniform vec3 u_coat_colour;       // linear RGB
uniform float u_coat_metalness;
uniform float u_coat_roughness;
uniform int u_surface;            // procedural detail (surface_detail.glsl)
uniform sampler2D u_base_texture; // TEXTURED: the mesh's own base-colour image (it replaces
                                  // u_base_colour), sRGB bytes, row 0 at texture v = 0
uniform float u_exposure;         // scene-referred scale before the tone curve
uniform vec2 u_uv_per_metre;      // texture-space length of one metre along +u and +v
uniform float u_max_depth;        // deepest possible dent, metres (parallax search range)
uniform float u_legend_depth;     // the height view's full-scale depth, metres (the legend's)

in vec3 v_world;
in vec2 v_uv;
in vec3 v_normal;
in vec3 v_tangent;
in vec3 v_bitangent;
in vec4 v_light_clip;
in vec2 v_texture_uv;
#if DISPLACE
in float v_displaced_depth;  // metres the vertices moved inwards, interpolated
#define DISPLACED_DEPTH v_displaced_depth
#else
#define DISPLACED_DEPTH 0.0
#endif

out vec4 f_colour;

// Height below the mesh surface in metres at uv (positive = deeper).
float depth_at(vec2 uv) { return -texture(u_height_map, uv).r; }

// Depth of the height field below the drawn surface at uv, metres (the drawn surface is the mesh,
// or the mesh moved by DISPLACED_DEPTH where it was displaced).
float relief_at(vec2 uv) { return depth_at(uv) - DISPLACED_DEPTH; }

// March the view ray (tangent space, metres) into the height field; return the uv it meets.
vec2 parallax_uv(vec2 uv, vec3 view_ts) {
    if (u_max_depth <= 0.0 || view_ts.z <= 0.05) return uv;
    const int STEPS = 24;
    float layer = u_max_depth / float(STEPS);
    vec2 step_uv = -view_ts.xy / view_ts.z * layer * u_uv_per_metre;
    float ray = 0.0;
    vec2 cur = uv;
    float surf = relief_at(cur);
    for (int i = 0; i < STEPS && ray < surf; ++i) {
        cur += step_uv;
        ray += layer;
        surf = relief_at(cur);
    }
    vec2 prev = cur - step_uv;
    float after = surf - ray;
    float before = relief_at(prev) - (ray - layer);
    float t = after / max(after - before, 1e-9);
    return mix(cur, prev, clamp(t, 0.0, 1.0));
}

float shadow_factor(vec3 n) {
    vec3 p = v_light_clip.xyz / v_light_clip.w * 0.5 + 0.5;
    if (any(lessThan(p, vec3(0.0))) || any(greaterThan(p, vec3(1.0)))) return 1.0;
    float bias = 0.0015 + 0.002 * (1.0 - max(dot(n, -u_light_dir), 0.0));
#if SHADOW_TAPS == 1
    return texture(u_shadow_map, vec3(p.xy, p.z - bias));
#else
    vec2 texel = 1.0 / vec2(textureSize(u_shadow_map, 0));
    float lit = 0.0;
    for (int i = 0; i < 4; ++i) {  // four bilinear comparisons: a 3 x 3 texel PCF
        vec2 offset = (vec2(i & 1, i >> 1) - 0.5) * texel;
        lit += texture(u_shadow_map, vec3(p.xy + offset, p.z - bias));
    }
    return lit * 0.25;
#endif
}

// Prefiltered radiance along d for a roughness: bilinear within a row, linear between rows.
vec3 radiance(vec3 d, float roughness) {
    vec2 uv = equirect_uv(d);
    float row = clamp(roughness, 0.0, 1.0) * float(u_levels - 1);
    float r0 = floor(row);
    float r1 = min(r0 + 1.0, float(u_levels - 1));
    float texel_v = 1.0 / float(textureSize(u_radiance, 0).y);
    float v = clamp(uv.y, 0.5 * float(u_levels) * texel_v, 1.0 - 0.5 * float(u_levels) * texel_v);
    vec3 a = texture(u_radiance, vec2(uv.x, (r0 + v) / float(u_levels))).rgb;
    vec3 b = texture(u_radiance, vec2(uv.x, (r1 + v) / float(u_levels))).rgb;
    return mix(a, b, row - r0);
}

// GGX normal distribution, Smith-Schlick visibility and Schlick Fresnel.
float ggx(float nh, float a) {
    float a2 = a * a, d = nh * nh * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}
float smith_visibility(float nv, float nl, float roughness) {
    float k = (roughness + 1.0) * (roughness + 1.0) / 8.0;
    return 0.25 / ((nv * (1.0 - k) + k) * (nl * (1.0 - k) + k));
}
vec3 fresnel(float cos_theta, vec3 f0) {
    float m = 1.0 - cos_theta, m2 = m * m;  // (1 - cos)^5 by products: pow() is exp2(log2()),
    return f0 + (1.0 - f0) * (m2 * m2 * m);  // which a software rasteriser pays for per pixel
}

// The split-sum environment BRDF, analytic fit (B. Karis, "Physically based shading on mobile").
vec2 env_brdf(float nv, float roughness) {
    const vec4 c0 = vec4(-1.0, -0.0275, -0.572, 0.022);
    const vec4 c1 = vec4(1.0, 0.0425, 1.04, -0.04);
    vec4 r = roughness * c0 + c1;
    float a004 = min(r.x * r.x, exp2(-9.28 * nv)) * r.x + r.y;
    return vec2(-1.04, 1.04) * a004 + r.zw;
}

void main() {
    vec3 view = normalize(u_camera_pos - v_world);
#if GROUND
    vec2 uv = v_uv;
    vec3 n = vec3(0.0, 1.0, 0.0);
#else
    mat3 tbn = mat3(normalize(v_tangent), normalize(v_bitangent), normalize(v_normal));
#if PARALLAX
    vec2 uv = parallax_uv(v_uv, transpose(tbn) * view);
#else
    vec2 uv = v_uv;
#endif
    vec3 n = normalize(tbn * decode_normal(texture(u_normal_map, uv).rgb));
#endif
#if VIEW != 0
    // Debug views: outlines where a body turns away from the view (silhouettes, plate edges),
    // so that touching bodies do not merge into one plane.
    float facing = abs(dot(normalize(v_normal), view));
    float outline = smoothstep(0.08, 0.3, facing);
#if VIEW == 1
    float t = depth_at(uv) / max(u_legend_depth, 1e-9);
    vec3 shown = depth_ramp(t);
#else
    vec3 shown = texture(u_normal_map, uv).rgb;
#endif
#if GROUND  // the ground recedes, so that bodies stand out from it
    vec2 square = floor(v_world.xz / 0.25);
    shown *= mod(square.x + square.y, 2.0) < 0.5 ? 0.45 : 0.38;
#endif
    f_colour = vec4(shown * mix(0.15, 1.0, outline), 1.0);
    return;
#endif
    vec3 base = u_base_colour;
#if TEXTURED
    base = srgb_to_linear(texture(u_base_texture, v_texture_uv).rgb);
#endif
    float roughness = u_roughness;
#if SURFACE_DETAIL
    surface_detail(u_surface, uv, v_world, base, roughness);
#endif
    float metalness = u_metalness;
#if GROUND
    vec2 cell = floor(v_world.xz / 0.25);
    base *= mod(cell.x + cell.y, 2.0) < 0.5 ? 1.0 : 0.75;
#else
    // The coat covers the texel unless a dent or scratch goes deeper than it (the rule of
    // Appearance.coated and of the glTF export's textures).
    if (u_coat_thickness > 0.0 && depth_at(uv) <= u_coat_thickness) {
        base = u_coat_colour;
        roughness = u_coat_roughness;
        metalness = u_coat_metalness;
    }
#endif
    roughness = clamp(roughness, 0.03, 1.0);
    float a = roughness * roughness;
    vec3 f0 = mix(vec3(0.04), base, metalness);
    vec3 diffuse_colour = base * (1.0 - metalness);
    float nv = max(dot(n, view), 1e-4);

    // The sun.
    vec3 l = -u_light_dir;
    float nl = max(dot(n, l), 0.0);
    vec3 colour = vec3(0.0);
    if (nl > 0.0) {
        vec3 h = normalize(l + view);
        vec3 f = fresnel(max(dot(view, h), 0.0), f0);
        vec3 specular = ggx(max(dot(n, h), 0.0), a) * smith_visibility(nv, nl, roughness) * f;
        vec3 diffuse = (1.0 - f) * diffuse_colour / PI;
        colour += (diffuse + specular) * u_light_colour * nl * shadow_factor(normalize(v_normal));
    }
    // The environment.
    vec3 r = reflect(-view, n);
    vec2 ab = env_brdf(nv, roughness);
    vec3 specular_ibl = radiance(r, roughness) * (f0 * ab.x + ab.y);
#if GROUND
    vec3 irradiance = texture(u_irradiance, vec2(0.5, 1.0)).rgb;  // straight up: the top row
#else
    vec3 irradiance = texture(u_irradiance, equirect_uv(n)).rgb;
#endif
    vec3 diffuse_ibl = irradiance * diffuse_colour;
    colour += (specular_ibl + diffuse_ibl) * u_ambient;
    f_colour = vec4(tonemap(colour, u_exposure), 1.0);
}
