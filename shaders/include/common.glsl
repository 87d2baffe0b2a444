// Shared helpers. Units: metres for positions and heights; uv in [0, 1]; row 0 of a texture is v = 0.

// Pack a tangent-space normal in [-1, 1]^3 into a [0, 1] colour, and back.
vec3 encode_normal(vec3 n) { return n * 0.5 + 0.5; }
vec3 decode_normal(vec3 c) { return normalize(c * 2.0 - 1.0); }
