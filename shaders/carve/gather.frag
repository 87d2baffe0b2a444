#version 330 core
// ---- Pass 4: gather into the height map ---------------------------------------------------------
// One fragment per texel of the target's surface map inside the footprint (texel.vert, .geom). The
// texel's own centre on the surface (world point and normal; a built-in sphere or capsule moves it
// along its normal onto its smooth surface) is projected into the collision
// camera, checked against the address map (is this the surface the camera saw there?) and compared
// with the tool's deepest point along the view (pass 3, bilinear between camera pixels): that is
// the back of the solid the tool sweeps from first touch. The new height moves the texel's point
// inwards along its normal until it leaves that solid: the a >= 0 (metres) with
//     a = (tool depth at the pixel of (point - a normal) - surface depth) / max(cos, MIN_COS)
// (cos = cos(normal, -forward)), or where the moved point's view line leaves the tool's outline:
// the view-line estimate at the point's own pixel where the normal is the press direction (exact,
// no search), else a march and bisection monotone in the tool (exit.glsl). h = -a. It does not
// depend on the old height, so an identical press writes identical values; blending MIN keeps the
// deeper of old and new (dents only deepen, presses are idempotent).
#ifndef EXIT
#define EXIT 1
#endif
// Drawn instanced (texel.vert, texel.geom, util/rect.vert): the entry from the stage before.
flat in int v_job;
#define JOB v_job
#include "camera.glsl"
#include "chart.glsl"
#include "texel.glsl"
#include "swept.glsl"
#include "exit.glsl"

#ifndef CONVEX  // the target hides none of its own surface: pass 2 drew no address map for it
#define CONVEX 0
#endif

uniform sampler2D u_address;     // pass 2: (u, v, view depth, bumped view depth)
// u_min_height, u_ceiling, u_pixel_diagonal and u_advance: the job's entry (job.glsl).

out float f_height;

void main() {
#if RECT
    if (!rect_triangle()) discard;  // no chart texel (the gutter draw has it)
#endif
    vec3 face = texel_face_normal();
#if GUTTER
    if ((chart_bits(ivec2(gl_FragCoord.xy)) & CHART_SELF) != 0u) discard;  // GUTTER 0 has it
#endif
    vec3 world, n;
    ivec2 source;
    if (!texel_surface(world, n, source)) discard;
#if SWEPT
    swept_snap(world, n);  // a built-in sphere or capsule: its smooth surface
#endif
    float cos_view = -dot(n, u_forward);
#if SWEPT
    bool front = cos_view > 0.0;  // the solid's own normal
#else
    // A mesh is its triangles: a texel faces the camera where its triangle does (the address pass
    // culls by the triangle's winding), also where the interpolated normal of a sharply curved
    // triangle turns away (then the grazing clamp MIN_COS applies below).
    bool front = cos_view > 0.0 || dot(face, u_forward) < 0.0;
#endif
    if (!front) discard;  // faces away from the camera
    vec3 rel = world - u_eye;
    float depth = dot(rel, u_forward);  // view depth of the texel's point, metres
    vec2 p = camera_pixel(rel);
    // Hidden: each of the four pixels around Q that the camera has sees a surface nearer than
    // this texel's by more than the slope over a pixel. The texel's surface at a pixel is its own
    // point or, for a mesh, the plane of its triangle (which the address pass drew: a sharply
    // curved triangle is steeper than its interpolated normal says) extended to the pixel's
    // centre. A pixel that sees no surface or one farther away (past the silhouette, or past a
    // triangle narrower than a pixel) hides nothing; where a pixel spans several texels, the
    // nearest one alone may lie past the edge of the texel's face.
    float slope = sqrt(max(1.0 - cos_view * cos_view, 0.0)) / max(cos_view, MIN_COS);
    float tolerance = u_pixel_diagonal * (1.0 + slope);
    float face_s = dot(face, u_forward);
    bool plane = SWEPT == 0 && abs(face_s) > 1e-6 * length(face);
    vec2 pixel_metres = 2.0 * u_half_extent / vec2(u_resolution);
    ivec2 base = ivec2(floor(p));
    ivec2 first = ivec2(floor(p + 0.5)) - base;  // the nearest of the four first: it mostly sees
    bool seen = false;
    for (int k = 0; k < 4 && !seen; ++k) {
        ivec2 q = base + (first ^ ivec2(k & 1, k >> 1));
        if (!inside_camera(q)) continue;
#if CONVEX
        // Every surface a pixel sees is at or behind the plane of each face turned towards it
        // (the convex solid lies behind each), so the test below would always pass.
        seen = true;
#else
        vec4 address = texelFetch(u_address, q + u_tile, 0);
        float own = depth;
        if (plane) {
            vec2 step = (vec2(q) - p) * pixel_metres;
            own = min(own, depth - (dot(face, u_right) * step.x + dot(face, u_up) * step.y) / face_s);
        }
        seen = seen || address.x <= NO_SURFACE || address.z >= own - tolerance;
#endif
    }
    if (!seen) discard;
    float tool, thickness;
    if (!tool_at(p, tool, thickness) || !(thickness > 0.0)) discard;  // outside the tool's outline
    // Behind the tool: in front of its nearest face at first touch (pass 3's front, less the
    // advance), as a ledge overhanging it is; pass 2 drew no such surface. Where the nearest
    // pixel does not see the tool (at its outline), the front tool_at extends to the texel.
    ivec2 near = ivec2(floor(p + 0.5));
    vec4 extent = inside_camera(near) ? texelFetch(u_tool_depth, near + u_tile, 0) : vec4(NO_FRONT);
    if (extent.a >= 0.5 * NO_FRONT && thickness < 0.5 * INSIDE_OUTLINE) extent.a = tool - thickness;
    if (extent.a < 0.5 * NO_FRONT && depth < extent.a - u_advance - tolerance) discard;
    float stretch = 1.0 / max(cos_view, MIN_COS);
    float inward = (tool - depth) * stretch;
    // Along the normal, not the view: the moved point sees another pixel (none when n = -forward).
#if EXIT  // some normal of the footprint is not the press direction (a variant: a software
          // rasteriser runs an if's body for every fragment, so square-on presses leave it out)
    if (inward > 0.0 && cos_view < 1.0 - 1e-6)
        inward = normal_exit(rel, n, depth, stretch, max(depth - tool, -thickness), u_advance);
#endif
    float h = -inward;
    if (!(h < u_ceiling)) discard;  // the tool does not reach this texel
    // No deeper than the material's bound, nor than the body is thick under the texel.
    f_height = max(h, max(u_min_height, -texel_thickness()));
}
