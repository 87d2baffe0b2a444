// Displacement by the height map: metres along the surface normal (< 0 in a dent), read bilinearly
// through u_displacement_map (the height map with a linear sampler; lit.frag reads the same map
// texel by texel as u_height_map). Positions and normals in the body's local space, metres.
uniform sampler2D u_displacement_map;

float height_at(vec2 uv) { return textureLod(u_displacement_map, uv, 0.0).r; }

vec3 displaced(vec3 position, vec3 normal, vec2 uv) {
    return position + normalize(normal) * height_at(uv);
}
