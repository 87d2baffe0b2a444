#version 330 core
// A rectangle in pixels (for overlays; the carve's texel rectangles, RECT 1), drawn as a triangle
// strip of 4 vertices.
#ifndef RECT_TABLE
#define RECT_TABLE 0
#endif
#if RECT_TABLE  // the carve's: drawn instanced, instance i is rectangle u_rect_first + i of the
                // batch's table (carve/jobs.py): its texels, then its job's entry
layout(std140) uniform CarveRects {
    ivec4 u_rect_table[2 * RECT_ENTRIES];
};
uniform int u_rect_first;
flat out int v_job;  // the job's entry in the job table's range bound
#else
uniform vec4 u_rect;      // x, y, width, height in pixels
#endif
uniform vec2 u_viewport;  // pixels
#ifdef CLIP_DISTANCES  // drawn under a state that enables this many clip distances: none clips
out float gl_ClipDistance[CLIP_DISTANCES];
#endif
void main() {
#if RECT_TABLE
    int i = 2 * (u_rect_first + gl_InstanceID);
    vec4 rect = vec4(u_rect_table[i]);
    v_job = u_rect_table[i + 1].x;
#else
    vec4 rect = u_rect;
#endif
    vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);
    vec2 pixel = rect.xy + corner * rect.zw;
    gl_Position = vec4(pixel / u_viewport * 2.0 - 1.0, 0.0, 1.0);
#ifdef CLIP_DISTANCES
    for (int k = 0; k < CLIP_DISTANCES; ++k) gl_ClipDistance[k] = 1.0;
#endif
}
