// Procedural surface character per material (base colour and roughness only: dents live in the
// height map alone). 0 plain, 1 brushed metal (fine streaks along +u), 2 cast (mottled), 3 wood
// grain (rings in world space), 4 matte (faint speckle). uv in [0, 1]; world in metres.
float hash12(vec2 p) {
    vec3 p3 = fract(vec3(p.xyx) * 0.1031);
    p3 += dot(p3, p3.yzx + 33.33);
    return fract((p3.x + p3.y) * p3.z);
}

float value_noise(vec2 p) {
    vec2 i = floor(p), f = fract(p);
    vec2 u = f * f * (3.0 - 2.0 * f);
    return mix(mix(hash12(i), hash12(i + vec2(1, 0)), u.x),
               mix(hash12(i + vec2(0, 1)), hash12(i + vec2(1, 1)), u.x), u.y);
}

void surface_detail(int kind, vec2 uv, vec3 world, inout vec3 base, inout float roughness) {
    if (kind == 1) {  // brushed: soft streaks along +u, 600 per uv unit across
        float streak = value_noise(vec2(uv.x * 12.0, uv.y * 600.0));
        roughness *= 0.9 + 0.2 * streak;
        base *= 0.98 + 0.03 * streak;
    } else if (kind == 2) {  // cast: blotches a few centimetres across
        float m = value_noise(world.xz * 40.0) * 0.6 + value_noise(world.xz * 160.0) * 0.4;
        roughness *= 0.8 + 0.5 * m;
        base *= 0.9 + 0.15 * m;
    } else if (kind == 3) {  // grain: rings about 1.5 cm apart, wobbling
        float rings = fract((world.x + 0.03 * value_noise(world.xz * 6.0)) * 65.0);
        float dark = smoothstep(0.0, 0.35, rings) * (1.0 - smoothstep(0.55, 1.0, rings));
        base *= 0.8 + 0.3 * dark;
        roughness *= 0.9 + 0.2 * dark;
    } else if (kind == 4) {  // matte: a faint speckle
        base *= 0.94 + 0.08 * hash12(floor(uv * 4096.0));
    }
}
