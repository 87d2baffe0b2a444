// Every value a carve pass takes per direction of a hit (a job) and per body it draws, as one
// uniform block (std140) at binding 0: the carver packs each pass's block of every job of a batch
// into one buffer (gl/blocks.py) and binds its range for each draw, in place of a dozen uniform
// writes a draw. World space, metres, unless said otherwise.
#ifndef CARVE_JOB_GLSL
#define CARVE_JOB_GLSL
layout(std140) uniform CarveJob {
    mat4 u_model;           // the drawn body's world from local
    mat3 u_normal_matrix;   // its world from local, for normals
    mat3 u_swept_local;     // its local from world, for a direction (the pose inverted)
    vec3 u_eye;             // camera origin
    float u_advance;        // how far the tool was advanced along u_forward
    vec3 u_right;           // unit; screen +x
    float u_near_clip;      // pass 2: no surface nearer than this view depth (it lies behind the tool)
    vec3 u_up;              // unit; screen +y
    float u_min_height;     // pass 4: -max_dent_depth of the target
    vec3 u_forward;         // unit; the press direction, into the screen
    float u_ceiling;        // pass 4: no texel of the target is higher than this
    vec3 u_swept_a;         // a built-in sphere or capsule: its sphere of u_swept_radius swept
    float u_swept_radius;   //   from u_swept_a to u_swept_b (both ends equal: a sphere)
    vec3 u_swept_b;
    float u_pixel_diagonal; // pass 4: a camera pixel's diagonal
    vec3 u_capsule;         // a capsule, local metres: radius, half the straight length; rows per hemisphere
    float u_cube_radius;    // a sphere drawn as rectangles of texels: its radius, local metres
    vec2 u_half_extent;     // half width and height of the view
    vec2 u_depth_range;     // near and far distance along u_forward from u_eye
    ivec2 u_resolution;     // camera pixels (columns, rows) in use in the scratch buffers
    ivec2 u_tile;           // the camera's pixel (0, 0) in the scratch atlas (passes 2, 3 draw
                            //   there through the viewport; pass 4 reads there)
    vec2 u_clip_half;       // passes 4, 5: half width and height of the kept rectangle, camera metres
    vec2 u_slab;            // passes 4, 5: kept view depths [near, far] along u_forward from u_eye
    ivec2 u_map_size;       // surface-map texels (columns, rows)
    int u_cube_grid;        // a sphere drawn as rectangles: cells along each cube-face edge
    bool u_clip;            // passes 4, 5: false: the whole map (creation, import)
};
#endif
