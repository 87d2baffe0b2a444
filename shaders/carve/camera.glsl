// The orthographic collision camera (world space, metres).
#ifndef QUAD
#define QUAD 0  // 1, 2: a built-in sphere, capsule drawn as one quad (quad.vert) in passes 2, 3
#endif
// u_eye, u_right, u_up, u_forward, u_half_extent, u_depth_range, u_resolution and u_tile
// (the camera's pixel (0, 0) in the scratch atlas): the job's entry (job.glsl).
#include "job.glsl"

// Window depth in [0, 1] of a view depth in metres (linear: the camera is orthographic).
float window_depth(float depth) {
    return clamp((depth - u_depth_range.x) / (u_depth_range.y - u_depth_range.x), 0.0, 1.0);
}

// Continuous camera-pixel coordinates of a world offset from the eye: the centre of pixel (i, j)
// is at (i, j).
vec2 camera_pixel(vec3 rel) {
    vec2 ndc = vec2(dot(rel, u_right) / u_half_extent.x, dot(rel, u_up) / u_half_extent.y);
    return (ndc * 0.5 + 0.5) * vec2(u_resolution) - 0.5;
}

bool inside_camera(ivec2 pixel) {
    return all(greaterThanEqual(pixel, ivec2(0))) && all(lessThan(pixel, u_resolution));
}

// The world point at view depth 0 on the view line through window position `frag` (gl_FragCoord:
// the tile's pixel centres), from the pixel's index alone.
vec3 camera_line(vec2 frag) {
    vec2 ndc = (frag - vec2(u_tile)) / vec2(u_resolution) * 2.0 - 1.0;
    return u_eye + u_right * (ndc.x * u_half_extent.x) + u_up * (ndc.y * u_half_extent.y);
}
