// A built-in sphere or capsule as its own smooth solid rather than its facets: a sphere of radius
// u_swept_radius swept from u_swept_a to u_swept_b (world metres; both ends equal: a sphere).
// SWEPT 0 (a compile-time variant, not a uniform branch: llvmpipe runs both sides of every branch):
// the mesh's facets are the surface.
#ifndef SWEPT
#define SWEPT 0
#endif
// u_swept_a, u_swept_b, u_swept_radius: the job's entry (job.glsl, through camera.glsl).

vec3 swept_axis_point(vec3 p) {
    vec3 ab = u_swept_b - u_swept_a;
    float len2 = dot(ab, ab);
    float t = len2 > 0.0 ? clamp(dot(p - u_swept_a, ab) / len2, 0.0, 1.0) : 0.0;
    return u_swept_a + t * ab;
}

// Move p along the solid's normal onto its surface; n is that normal (world).
void swept_snap(inout vec3 p, out vec3 n) {
    vec3 c = swept_axis_point(p);
    n = normalize(p - c);
    p = c + u_swept_radius * n;
}

// Where the line from `ro` along unit `rd` first enters the solid, or -1 when it misses.
#if QUAD == 1
// A sphere drawn as one quad: its cap alone, the same arithmetic as the general case's (whose
// cylinder and second cap, the same sphere, the rasteriser would work out for every fragment).
float swept_enter(vec3 ro, vec3 rd) {
    vec3 oc = ro - u_swept_a;
    float b = dot(rd, oc);
    float h = b * b - (dot(oc, oc) - u_swept_radius * u_swept_radius);
    if (h < 0.0) return -1.0;
    float t = -b - sqrt(h);
    return t >= 0.0 ? t : -1.0;
}
#else
float swept_enter(vec3 ro, vec3 rd) {
    vec3 ba = u_swept_b - u_swept_a, oa = ro - u_swept_a;
    float baba = dot(ba, ba), bard = dot(ba, rd), baoa = dot(ba, oa);
    float r2 = u_swept_radius * u_swept_radius;
    if (baba > 1e-20) {  // the cylinder between the caps
        float a = baba - bard * bard;
        float b = baba * dot(rd, oa) - baoa * bard;
        float c = baba * dot(oa, oa) - baoa * baoa - r2 * baba;
        float h = b * b - a * c;
        if (h >= 0.0 && a > 1e-20) {
            float t = (-b - sqrt(h)) / a;
            float y = baoa + t * bard;
            if (y > 0.0 && y < baba) return t;
        }
    }
    // The end spheres (one sphere when both ends are equal): the nearer entry of the two.
    float best = -1.0;
    for (int k = 0; k < 2; ++k) {
        vec3 oc = ro - (k == 0 ? u_swept_a : u_swept_b);
        float b = dot(rd, oc);
        float h = b * b - (dot(oc, oc) - r2);
        if (h >= 0.0) {
            float t = -b - sqrt(h);
            if (t >= 0.0 && (best < 0.0 || t < best)) best = t;
        }
    }
    return best;
}
#endif

// The view depth (metres along u_forward from u_eye) where the view line through world point p
// enters (front) or leaves (back) the solid; keeps `depth` where the line misses. The line starts
// just outside the solid, not far away, so that float32 keeps its precision at the silhouette.
float swept_view_depth(vec3 p, float depth, bool back, vec3 eye, vec3 forward) {
    vec3 centre = 0.5 * (u_swept_a + u_swept_b);
    float extent = 0.5 * length(u_swept_b - u_swept_a) + u_swept_radius + 1e-4;
    vec3 dir = back ? -forward : forward;
    vec3 start = p + forward * dot(centre - p, forward) - dir * extent;
    float t = swept_enter(start, dir);
    if (t < 0.0) return depth;
    return dot(start + dir * t - eye, forward);
}
