// Every value a carve pass takes per direction of a hit (a job) and per body it draws, as one
// entry of a std140 array in one uniform buffer a batch (binding 0): the carver writes every
// entry of a batch at once (carve/jobs.py) and each draw names its entry with u_job. The names
// the passes read (u_eye, u_model, ...) stand for the entry's members. World space, metres,
// unless said otherwise. JOB_ENTRIES (the array's length: what the driver's uniform blocks hold,
// at least the 40 GL 3.3's smallest holds) comes from carve/jobs.py's job_entries; RING 1 in pass
// 5's programs.
#ifndef CARVE_JOB_GLSL
#define CARVE_JOB_GLSL
#ifndef RING
#define RING 0
#endif
struct CarveEntry {
    mat4 model;            // the drawn body's world from local
    mat3 normal_matrix;    // its world from local, for normals
    mat3 swept_local;      // its local from world, for a direction (the pose inverted)
    vec3 eye;              // camera origin
    float advance;         // how far the tool was advanced along forward
    vec3 right;            // unit; screen +x
    float near_clip;       // pass 2: no surface nearer than this view depth (behind the tool)
    vec3 up;               // unit; screen +y
    float min_height;      // pass 4: -max_dent_depth of the target
    vec3 forward;          // unit; the press direction, into the screen
    float ceiling;         // pass 4: no texel of the target is higher than this
    vec3 swept_a;          // a built-in sphere or capsule: its sphere of swept_radius swept
    float swept_radius;    //   from swept_a to swept_b (both ends equal: a sphere)
    vec3 swept_b;
    float pixel_diagonal;  // pass 4: a camera pixel's diagonal
    vec3 capsule;          // a capsule, local metres: radius, half the straight length, rows
                           //   per hemisphere
    float cube_radius;     // a sphere drawn as rectangles of texels: its radius, local metres
    vec2 half_extent;      // half width and height of the view
    vec2 depth_range;      // near and far distance along forward from eye
    ivec2 resolution;      // camera pixels (columns, rows) in use in the scratch buffers
    ivec2 tile;            // the camera's pixel (0, 0) in the scratch atlas (passes 2, 3 draw
                           //   there through the viewport; pass 4 reads there)
    vec2 clip_half;        // passes 4, 5: half width and height of the kept rectangle, camera m
    vec2 slab;             // pass 4: kept view depths [near, far] along forward from eye
    vec2 ring_slab;        // pass 5: the same, grown by the ring whose normals read a change
    ivec2 map_size;        // surface-map texels (columns, rows)
    int cube_grid;         // a sphere drawn as rectangles: cells along each cube-face edge
    bool clip;             // passes 4, 5: false: the whole map (creation, import)
    ivec4 list_skip;       // pass 3, a tool drawn with the union of its jobs' lists: bit i
                           //   (of 128) set where triangle i of the list is another job's
};
layout(std140) uniform CarveJobs {
    CarveEntry u_entries[JOB_ENTRIES];
};
uniform int u_job;  // this draw's entry in the range bound (its first instance's)
#ifndef JOB  // the entry read: an instanced draw's stages name theirs (quad.vert)
#define JOB u_job
#endif

#define u_model u_entries[JOB].model
#define u_normal_matrix u_entries[JOB].normal_matrix
#define u_swept_local u_entries[JOB].swept_local
#define u_eye u_entries[JOB].eye
#define u_advance u_entries[JOB].advance
#define u_right u_entries[JOB].right
#define u_near_clip u_entries[JOB].near_clip
#define u_up u_entries[JOB].up
#define u_min_height u_entries[JOB].min_height
#define u_forward u_entries[JOB].forward
#define u_ceiling u_entries[JOB].ceiling
#define u_swept_a u_entries[JOB].swept_a
#define u_swept_radius u_entries[JOB].swept_radius
#define u_swept_b u_entries[JOB].swept_b
#define u_pixel_diagonal u_entries[JOB].pixel_diagonal
#define u_capsule u_entries[JOB].capsule
#define u_cube_radius u_entries[JOB].cube_radius
#define u_half_extent u_entries[JOB].half_extent
#define u_depth_range u_entries[JOB].depth_range
#define u_resolution u_entries[JOB].resolution
#define u_tile u_entries[JOB].tile
#define u_clip_half u_entries[JOB].clip_half
#if RING  // pass 5 keeps the ring around the slab
#define u_slab u_entries[JOB].ring_slab
#else
#define u_slab u_entries[JOB].slab
#endif
#define u_map_size u_entries[JOB].map_size
#define u_cube_grid u_entries[JOB].cube_grid
#define u_clip u_entries[JOB].clip
#define u_list_skip u_entries[JOB].list_skip
#endif
