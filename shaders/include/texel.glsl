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
