// Texture-space draws keep only the texels whose surface lies inside the collision camera's
// rectangle and depth slab (needs camera.glsl).
uniform bool u_clip;        // false: the whole map (creation, import)
uniform vec2 u_clip_half;   // half width and height of the kept rectangle, camera metres
uniform vec2 u_slab;        // kept view depths [near, far], metres along u_forward from u_eye

out float gl_ClipDistance[6];

void clip_to_footprint(vec3 world) {
    vec3 rel = world - u_eye;
    float x = dot(rel, u_right), y = dot(rel, u_up), z = dot(rel, u_forward);
    gl_ClipDistance[0] = u_clip ? u_clip_half.x - x : 1.0;
    gl_ClipDistance[1] = u_clip ? u_clip_half.x + x : 1.0;
    gl_ClipDistance[2] = u_clip ? u_clip_half.y - y : 1.0;
    gl_ClipDistance[3] = u_clip ? u_clip_half.y + y : 1.0;
    gl_ClipDistance[4] = u_clip ? z - u_slab.x : 1.0;
    gl_ClipDistance[5] = u_clip ? u_slab.y - z : 1.0;
}
