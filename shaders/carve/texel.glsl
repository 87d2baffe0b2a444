// Fragment side of texel.vert / texel.geom: the surface point, normal and texel metric of the
// texel this fragment stands for. Needs GUTTER and GUTTER_REACH_TEXELS defined. RECT 1 (a built-in
// sphere drawn as rectangles of texels, GUTTER 0): the triangle comes from cube_grid.glsl per
// fragment (call rect_triangle() first) and is used as a gutter draw's is.
#ifndef RECT
#define RECT 0
#endif
#if GUTTER
flat in vec2 t_uv[3];      // triangle corners, texel units
flat in vec3 t_world[3];   // world metres
flat in vec3 t_normal[3];  // world
flat in float t_thickness[3];  // world metres
#elif RECT
vec2 t_uv[3];              // as above, written by rect_triangle()
vec3 t_world[3];
vec3 t_normal[3];
float t_thickness[3];
#define CLIP_IN_FRAGMENT 1
#include "clip.glsl"
#include "cube_grid.glsl"
#endif
#if GUTTER || RECT
vec3 texel_weights;  // texel_surface's barycentric weights of the texel's point

// Barycentric weights of the point of the triangle nearest to q (texel units); `dist` is the
// distance to it in texels (0 inside).
vec3 nearest_barycentric(vec2 q, out float dist) {
    vec2 e1 = t_uv[1] - t_uv[0], e2 = t_uv[2] - t_uv[0], r = q - t_uv[0];
    float den = e1.x * e2.y - e1.y * e2.x;
    float b1 = (r.x * e2.y - r.y * e2.x) / den, b2 = (e1.x * r.y - e1.y * r.x) / den;
    vec3 b = vec3(1.0 - b1 - b2, b1, b2);
    dist = 0.0;
    if (all(greaterThanEqual(b, vec3(0.0)))) return b;
    dist = 1e30;
    for (int i = 0; i < 3; ++i) {
        int j = (i + 1) % 3;
        vec2 edge = t_uv[j] - t_uv[i];
        float t = clamp(dot(q - t_uv[i], edge) / dot(edge, edge), 0.0, 1.0);
        float d = length(q - (t_uv[i] + t * edge));
        if (d < dist) {
            dist = d;
            b = vec3(0.0);
            b[i] = 1.0 - t;
            b[j] = t;
        }
    }
    return b;
}

// The texel's point: the point of the triangle nearest to the texel centre. False when the texel
// does not overlap the triangle. `source` is the texel that holds that point.
bool texel_surface(out vec3 world, out vec3 normal, out ivec2 source) {
    float dist;
    vec3 b = nearest_barycentric(gl_FragCoord.xy, dist);
    texel_weights = b;
    world = b.x * t_world[0] + b.y * t_world[1] + b.z * t_world[2];
    normal = normalize(b.x * t_normal[0] + b.y * t_normal[1] + b.z * t_normal[2]);
#if RECT  // the texel's centre lies on its own triangle (to rounding)
    source = ivec2(gl_FragCoord.xy);
    return inside_footprint(world);
#else
    source = ivec2(floor(b.x * t_uv[0] + b.y * t_uv[1] + b.z * t_uv[2]));
    return dist <= GUTTER_REACH_TEXELS;
#endif
}

// The body's thickness under the texel's point, world metres (after texel_surface).
float texel_thickness() {
    return dot(texel_weights, vec3(t_thickness[0], t_thickness[1], t_thickness[2]));
}
#else
in vec3 v_world;   // world metres, at the texel centre
in vec3 v_normal;  // world
in float v_thickness;  // world metres

float texel_thickness() { return v_thickness; }

bool texel_surface(out vec3 world, out vec3 normal, out ivec2 source) {
    world = v_world;
    normal = normalize(v_normal);
    source = ivec2(gl_FragCoord.xy);
    return true;
}
#endif

// The normal of the texel's triangle (world, not normalised) by the mesh's winding: the side from
// which the triangle is a front face, as the collision camera's passes cull it. Call it in uniform
// control flow (before any discard): it may take screen-space derivatives.
vec3 texel_face_normal() {
#if GUTTER || RECT
    return cross(t_world[1] - t_world[0], t_world[2] - t_world[0]);
#else
    // The world edges are the uv edges through dP/du and dP/dv: e1 x e2 = det(uv edges) (dP/du x
    // dP/dv), and the uv winding (counter-clockwise: det > 0) is what makes the fragment front
    // facing in this texture-space draw (every pass sets the front face to "ccw").
    vec3 n = cross(dFdx(v_world), dFdy(v_world));
    return gl_FrontFacing ? n : -n;
#endif
}

// The texel's metric (a, b, c), metres: one texel step along +u moves the surface by a T, one
// along +v by b T + c B (T, B unit and perpendicular in the surface, B on the side of +v). Call it
// in uniform control flow (before any discard): it may take screen-space derivatives.
vec3 texel_metric() {
#if GUTTER || RECT
    vec2 d1 = t_uv[1] - t_uv[0], d2 = t_uv[2] - t_uv[0];
    vec3 e1 = t_world[1] - t_world[0], e2 = t_world[2] - t_world[0];
    float det = d1.x * d2.y - d1.y * d2.x;
    vec3 per_u = (e1 * d2.y - e2 * d1.y) / det;  // metres per texel along +u
    vec3 per_v = (e2 * d1.x - e1 * d2.x) / det;  // metres per texel along +v
#else
    vec3 per_u = dFdx(v_world);  // texture-space raster: one pixel is one texel
    vec3 per_v = dFdy(v_world);
#endif
    float a = length(per_u);
    vec3 t = per_u / a;
    float b = dot(per_v, t);
    return vec3(a, b, length(per_v - b * t));
}
