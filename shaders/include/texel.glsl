// Texel addressing shared by every pass that maps texture coordinates to a surface-map texel.
// uv in [0, 1] (row 0 is v = 0); returns the integer texel that holds uv.
ivec2 texel_of(vec2 uv, ivec2 size) {
    return clamp(ivec2(floor(uv * vec2(size))), ivec2(0), size - 1);
}

// Whether texel t lies inside a map of `size` texels.
bool in_map(ivec2 t, ivec2 size) {
    return all(greaterThanEqual(t, ivec2(0))) && all(lessThan(t, size));
}

// Texel centre in normalized device coordinates of a viewport covering the whole map.
vec2 texel_ndc(ivec2 texel, ivec2 size) {
    return (vec2(texel) + 0.5) / vec2(size) * 2.0 - 1.0;
}

// A height map's value (metres) at uv: bilinear between the centres of the four texels around
// it, clamped at the map's edges; the surface the renderer displaces and shades (a sampler's
// LINEAR filter), where the texel that holds uv alone is a staircase of texels.
float height_at(sampler2D map, vec2 uv) {
    ivec2 size = textureSize(map, 0);
    vec2 p = uv * vec2(size) - 0.5;
    ivec2 base = ivec2(floor(p));
    vec2 f = p - vec2(base);
    ivec2 last = size - 1;
    float a = texelFetch(map, clamp(base, ivec2(0), last), 0).r;
    float b = texelFetch(map, clamp(base + ivec2(1, 0), ivec2(0), last), 0).r;
    float c = texelFetch(map, clamp(base + ivec2(0, 1), ivec2(0), last), 0).r;
    float d = texelFetch(map, clamp(base + ivec2(1, 1), ivec2(0), last), 0).r;
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}
