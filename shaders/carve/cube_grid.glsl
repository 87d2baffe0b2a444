// Passes 4 and 5 over a built-in sphere drawn as rectangles of texels (RECT 1, util/rect.vert):
// the facet under the fragment's texel centre, found from the sphere's own atlas rather than
// rasterised, and handed to texel.glsl as texel.geom hands a gutter draw its triangle. The atlas
// (mesh/primitives.py, sphere): each cube face an n x n grid of cells in its cell of the 3 x 2
// atlas, inside ATLAS_GUTTER; two triangles a cell, (c, r) (c+1, r) (c+1, r+1) and (c, r)
// (c+1, r+1) (c, r+1), counter-clockwise in uv; the vertex of grid point (c, r) on face f lies
// along N + tan(s pi/4) A + tan(t pi/4) B, s = 2c/n - 1, t = 2r/n - 1 (the equal-angle warp).
// Needs camera.glsl, chart.glsl, the CUBE_FACE_* and ATLAS_GUTTER defines, and texel.glsl's
// t_uv, t_world, t_normal, t_thickness (written here).
// u_model, u_normal_matrix, u_map_size, u_cube_grid (n: cells along each cube-face edge) and
// u_cube_radius (local metres): the job's entry (job.glsl).

// Grid point (c, r) of the cube face whose normal and s and t axes are `axes` (`warp`:
// tan(s pi/4), tan(t pi/4) there) as corner `i` of the triangle: its world point and normal, and
// its address (texels).
void cube_vertex(mat3 axes, ivec2 cr, vec2 warp, int i, vec2 cell, vec2 span) {
    vec3 unit = normalize(axes[0] + warp.x * axes[1] + warp.y * axes[2]);
    t_world[i] = (u_model * vec4(u_cube_radius * unit, 1.0)).xyz;
    t_normal[i] = u_normal_matrix * unit;
    t_uv[i] = (cell + vec2(cr) / float(u_cube_grid) * span) * vec2(u_map_size);
}

// The facet under this fragment's texel centre; false where the texel lies in no chart (the
// gutter draws have those) or its point outside the footprint.
bool rect_triangle() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    if ((chart_bits(texel) & CHART_SELF) == 0u) return false;
    vec2 uv = gl_FragCoord.xy / vec2(u_map_size);
    ivec2 col_row = clamp(ivec2(floor(uv * vec2(3.0, 2.0))), ivec2(0), ivec2(2, 1));
    int face = col_row.x + 3 * col_row.y;
    vec2 cell = vec2(col_row) / vec2(3.0, 2.0) + ATLAS_GUTTER;
    vec2 span = vec2(1.0 / 3.0, 0.5) - 2.0 * ATLAS_GUTTER;
    vec2 g = (uv - cell) / span * float(u_cube_grid);
    ivec2 cr = clamp(ivec2(floor(g)), ivec2(0), ivec2(u_cube_grid - 1));
    vec2 f = g - vec2(cr);
    // tan(s pi/4), tan(t pi/4) at the cell's lower and upper grid lines, s = 2c/n - 1.
    float step = 2.0 / float(u_cube_grid);
    vec2 lo = tan((vec2(cr) * step - 1.0) * 0.7853981633974483);
    vec2 hi = tan((vec2(cr + 1) * step - 1.0) * 0.7853981633974483);
    bool lower = f.x >= f.y;  // (c, r) (c+1, r) (c+1, r+1), else (c, r) (c+1, r+1) (c, r+1)
    // The face's axes looked up once (a table indexed per fragment costs the rasteriser a
    // gather a vector).
    mat3 axes = mat3(CUBE_FACE_N[face], CUBE_FACE_A[face], CUBE_FACE_B[face]);
    cube_vertex(axes, cr, lo, 0, cell, span);
    cube_vertex(axes, cr + ivec2(1, lower ? 0 : 1), vec2(hi.x, lower ? lo.y : hi.y), 1, cell, span);
    cube_vertex(axes, cr + ivec2(lower ? 1 : 0, 1), vec2(lower ? hi.x : lo.x, hi.y), 2, cell, span);
    float thickness = 2.0 * u_cube_radius * length(u_model[0].xyz);  // through the centre
    t_thickness = float[3](thickness, thickness, thickness);
    return true;
}
