// Texture-space draws keep only the texels whose surface lies inside the collision camera's
// rectangle and depth slab (needs camera.glsl): as clip distances of the vertices (texel.vert,
// texel.geom), or tested per fragment where CLIP_IN_FRAGMENT is 1 (RECT 1 draws one rectangle of
// texels, whose corners lie on no surface).
// u_clip (false: the whole map), u_clip_half (camera metres) and u_slab (view depths [near,
// far], metres): the job's entry (job.glsl).

// How far (metres) `world` lies inside each side of the footprint: the rectangle's four, then
// the slab's near and far; >= 0 inside all.
void footprint_distances(vec3 world, out float d[6]) {
    vec3 rel = world - u_eye;
    float x = dot(rel, u_right), y = dot(rel, u_up), z = dot(rel, u_forward);
    d[0] = u_clip ? u_clip_half.x - x : 1.0;
    d[1] = u_clip ? u_clip_half.x + x : 1.0;
    d[2] = u_clip ? u_clip_half.y - y : 1.0;
    d[3] = u_clip ? u_clip_half.y + y : 1.0;
    d[4] = u_clip ? z - u_slab.x : 1.0;
    d[5] = u_clip ? u_slab.y - z : 1.0;
}

#ifndef CLIP_IN_FRAGMENT
#define CLIP_IN_FRAGMENT 0
#endif
#if CLIP_IN_FRAGMENT
bool inside_footprint(vec3 world) {
    float d[6];
    footprint_distances(world, d);
    return min(min(min(d[0], d[1]), min(d[2], d[3])), min(d[4], d[5])) >= 0.0;
}
#else
out float gl_ClipDistance[6];

void clip_to_footprint(vec3 world) {
    float d[6];
    footprint_distances(world, d);
    for (int k = 0; k < 6; ++k) gl_ClipDistance[k] = d[k];
}
#endif
