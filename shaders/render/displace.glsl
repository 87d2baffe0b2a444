// Displacement by the height map: metres along the surface normal (< 0 in a dent), read bilinearly
// through u_displacement_map (the height map with a linear sampler; lit.frag reads the same map
// texel by texel as u_height_map). Positions and normals in the body's local space, metres.
uniform sampler2D u_displacement_map;

float height_at(vec2 uv) { return textureLod(u_displacement_map, uv, 0.0).r; }

// A point where charts of the map meet (render/seams.py): the mesh has a copy of it per chart;
// `twins` holds the other copies' addresses (this one's where there are none). Every copy moves
// by the deepest reading, the same for all, so the seam stays closed.
float seam_height(vec2 uv, vec4 twins) {
    return min(height_at(uv), min(height_at(twins.xy), height_at(twins.zw)));
}

// Whether the edge from corner i (address ui, twins ti) to corner j lies on a seam, and if so
// its ends' addresses in the chart on the other side (a, b): the pair of twins closest together
// in the atlas, as long as it is about as long there as here (two twins in different charts are
// far apart; an edge across a chart between two seams is no seam).
bool seam_edge(vec2 ui, vec4 ti, vec2 uj, vec4 tj, out vec2 a, out vec2 b) {
    vec2 ci[2] = vec2[2](ti.xy, ti.zw);
    vec2 cj[2] = vec2[2](tj.xy, tj.zw);
    float best = 1e9;
    a = ui;
    b = uj;
    for (int p = 0; p < 2; ++p) {
        for (int q = 0; q < 2; ++q) {
            float d = distance(ci[p], cj[q]);
            if (ci[p] != ui && cj[q] != uj && d < best) {
                best = d;
                a = ci[p];
                b = cj[q];
            }
        }
    }
    return best <= 2.0 * distance(ui, uj) + 1e-6;
}
