#version 330 core
// Passes 2 and 3 for a built-in sphere or capsule (QUAD 1, 2): one quad over the solid's extent in the
// collision camera instead of its facets; the fragment shader finds where each pixel's view line
// enters and leaves the exact solid (swept.glsl), so the facets' count changes nothing.
// The quads of one variant that sample one map are drawn instanced: instance i is the job table's
// entry u_job + i, handed on to the fragment stage. Each is placed in its camera's tile of the
// scratch atlas (ATLAS: its pixels) here, drawn with the whole atlas as the viewport.
#define JOB (u_job + gl_InstanceID)
#include "camera.glsl"
#include "swept.glsl"

out float gl_ClipDistance[CLIP_DISTANCES];  // every carve pass enables them: none clips
                                           // (pass 2's near clip is done per fragment here)
flat out int v_job;            // the entry this instance reads

void main() {
    v_job = JOB;
    vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);  // triangle strip, counter-clockwise
    vec3 ra = u_swept_a - u_eye, rb = u_swept_b - u_eye;
    vec2 pa = vec2(dot(ra, u_right), dot(ra, u_up)), pb = vec2(dot(rb, u_right), dot(rb, u_up));
    // Camera metres, grown by a pixel so that every pixel centre the solid covers is inside.
    vec2 grow = vec2(u_swept_radius) + 2.0 * u_half_extent / vec2(u_resolution);
    vec2 lo = min(pa, pb) - grow, hi = max(pa, pb) + grow;
    vec2 ndc = clamp(mix(lo, hi, corner) / u_half_extent, -1.0, 1.0);  // of the tile
    // Atlas pixels, then the atlas's NDC: the tile's edges are whole pixels, exact in float32.
    vec2 pixel = vec2(u_tile) + (ndc * 0.5 + 0.5) * vec2(u_resolution);
    gl_Position = vec4(pixel / ATLAS * 2.0 - 1.0, 0.0, 1.0);
    for (int k = 0; k < CLIP_DISTANCES; ++k) gl_ClipDistance[k] = 1.0;
}
