// The surface-map address of a point on a built-in sphere (mesh/primitives.py, sphere: a
// cube-sphere with the equal-angle warp, one chart per cube face in a 3 x 2 atlas), worked out
// from the point itself: passes drawn as one quad (QUAD 1) have no facet to interpolate it from.
// ATLAS_GUTTER comes from primitives.py as a define. The faces' axes are mesh/cube.py's
// CUBE_FACES (the CUBE_FACE_N, _A, _B defines), written out below as selects; the tests that
// carve a sphere drawn as one quad against its facets hold the two together (to 1e-6 m).
vec2 sphere_uv(vec3 world) {
    vec3 q = u_swept_local * (world - u_swept_a);
    vec3 m = abs(q);
    bool on_x = m.x >= m.y && m.x >= m.z, on_y = !on_x && m.y >= m.z;
    int face = on_x ? (q.x > 0.0 ? 0 : 1) : on_y ? (q.y > 0.0 ? 2 : 3) : (q.z > 0.0 ? 4 : 5);
    // q along the face's normal, s and t axes (CUBE_FACE_N, _A, _B of `face`), picked by selects
    // rather than by indexing the tables with a per-fragment face: the same values, for less.
    float qn = on_x ? m.x : on_y ? m.y : m.z;
    float qa = on_x ? (q.x > 0.0 ? -q.z : q.z) : on_y ? q.x : (q.z > 0.0 ? q.x : -q.x);
    float qb = on_y ? (q.y > 0.0 ? -q.z : q.z) : q.y;
    vec2 st = vec2(atan(qa / qn), atan(qb / qn)) / 0.7853981633974483;
    vec2 cell = vec2(float(face % 3) / 3.0, float(face / 3) / 2.0) + ATLAS_GUTTER;
    vec2 span = vec2(1.0 / 3.0, 0.5) - 2.0 * ATLAS_GUTTER;
    return cell + (st + 1.0) * 0.5 * span;
}
