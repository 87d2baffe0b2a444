// The surface-map address of a point on a built-in capsule (mesh/primitives.py, capsule: one
// surface of revolution about local z, u around it, v along the profile by its polyline's length:
// the lower hemisphere's rows, the straight side, the upper hemisphere's rows), worked out from the
// point itself, for passes drawn as one quad (QUAD 2). ATLAS_GUTTER comes from primitives.py.
// u_capsule (local metres: radius, half the straight length; rows per hemisphere): job.glsl.

vec2 capsule_uv(vec3 world) {
    const float HALF_PI = 1.5707963267948966, TWO_PI = 6.283185307179586;
    vec3 q = u_swept_local * (world - u_swept_a);  // local metres from the end a = (0, 0, -half)
    float r = u_capsule.x, half_len = u_capsule.y, rings = u_capsule.z;
    float z = q.z - half_len, rho = length(q.xy);
    float step = HALF_PI / rings;              // radians between the profile's rows
    float chord = 2.0 * r * sin(0.5 * step);   // the polyline's length between them
    float total = 2.0 * rings * chord + 2.0 * half_len;
    float arc = z < -half_len ? (atan(z + half_len, rho) + HALF_PI) / step * chord
              : z > half_len ? rings * chord + 2.0 * half_len + atan(z - half_len, rho) / step * chord
              : rings * chord + z + half_len;
    float phi = atan(q.y, q.x);
    if (phi < 0.0) phi += TWO_PI;
    return ATLAS_GUTTER + vec2(phi / TWO_PI, arc / total) * (1.0 - 2.0 * ATLAS_GUTTER);
}
