// Passes 2 and 3 drawn as one quad (QUAD 1: a built-in sphere, QUAD 2: a built-in capsule): the
// surface-map address of a point on the solid, from the point itself.
// u_swept_local (local from world, for a direction): the job's entry (job.glsl).

#if QUAD == 1
#include "sphere_uv.glsl"
vec2 quad_uv(vec3 world) { return sphere_uv(world); }
#else
#include "capsule_uv.glsl"
vec2 quad_uv(vec3 world) { return capsule_uv(world); }
#endif
