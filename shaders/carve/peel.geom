#version 330 core
// Pass 3, a tool drawn as its triangles: each triangle passed through with its three corners as
// flat values, so that peel.frag finds a pixel's depth, uv and normal where the pixel's own view
// line meets the triangle's plane (from the pixel's index in its tile). The rasteriser's
// interpolation rounds by the window position, so a tool's values would depend on where the
// camera's tile lies in the atlas, that is, on the rest of the batch.
// TILED 1: drawn instanced over jobs whose lists differ, as the union of their lists: the
// triangles of the list that are not the instance's job's (u_list_skip) are dropped here.
#ifndef TILED
#define TILED 0
#endif
#if TILED
flat in int g_job[];  // surface.vert: the job table's entry of the instance
#define JOB g_job[0]
#include "job.glsl"
flat out int v_job;   // the entry, for the fragment stage
#endif
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

in vec2 g_uv[];
in float g_depth[];
in vec3 g_normal[];
in vec3 g_world[];
in vec2 g_ndc[];  // the tile's normalised device coordinates

out vec2 v_uv;
out float v_depth;
out vec3 v_normal;
out vec3 v_world;
flat out vec3 t_world[3];   // world metres
flat out vec2 t_uv[3];      // the tool's surface-map address
flat out vec3 t_normal[3];  // world, vertex normals
out float gl_ClipDistance[CLIP_DISTANCES];

void main() {
#if TILED
    int i = gl_PrimitiveIDIn;  // the triangle's place in the draw's list
    // list_skip's bits (carve/params.py, Subset): set where it is another job's.
    if (i < SUBSET_TRIANGLES && ((u_list_skip[i >> 5] >> (i & 31)) & 1) != 0) return;
#endif
    for (int k = 0; k < 3; ++k) {
        for (int i = 0; i < 3; ++i) {
            t_world[i] = g_world[i];
            t_uv[i] = g_uv[i];
            t_normal[i] = g_normal[i];
        }
        v_uv = g_uv[k];
        v_depth = g_depth[k];
        v_normal = g_normal[k];
        v_world = g_world[k];
#if TILED
        v_job = JOB;
#endif
        // Every carve pass enables CLIP_DISTANCES; TILED: 1-4 the tile's edges (ndc -1 and 1, whole
        // pixels of the atlas: the clip keeps the pixels the tile's viewport gave, and nothing
        // outside it), the rest unused.
        for (int c = 0; c < CLIP_DISTANCES; ++c) gl_ClipDistance[c] = 1.0;
#if TILED
        gl_ClipDistance[1] = 1.0 - g_ndc[k].x;
        gl_ClipDistance[2] = 1.0 + g_ndc[k].x;
        gl_ClipDistance[3] = 1.0 - g_ndc[k].y;
        gl_ClipDistance[4] = 1.0 + g_ndc[k].y;
#endif
        gl_Position = gl_in[k].gl_Position;
        EmitVertex();
    }
    EndPrimitive();
}
