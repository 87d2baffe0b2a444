// Pass 4's look-ups of the tool's extent (pass 3) and the search for where a texel's point, moved
// inwards along its normal, leaves the solid the tool sweeps (docs/carve.md, pass 4 step 6).
// Needs camera.glsl and EXIT defined (gather.frag). Depths and thicknesses are metres along
// u_forward; positions are continuous camera pixels (the centre of pixel (i, j) at (i, j)). The
// thickness is the tool's along the view line (back - front), not the target's under a texel.
uniform sampler2D u_tool_depth;  // pass 3: (back view depth m, coverage, -, front), LINEAR

// The tool at one camera pixel: (back view depth, thickness back - front), the thickness
// INSIDE_OUTLINE where no front face was drawn (an open tool); false where the pixel, or the
// camera there, does not see the tool.
bool tool_pixel(ivec2 pixel, out vec2 tool) {
    tool = vec2(NO_TOOL, 0.0);
    if (!inside_camera(pixel)) return false;
    vec4 extent = texelFetch(u_tool_depth, pixel + u_tile, 0);
    tool = vec2(extent.r, extent.a < 0.5 * NO_FRONT ? extent.r - extent.a : INSIDE_OUTLINE);
    return extent.g > 0.5;
}

// (back, thickness) at a pixel that does not see the tool, from the pixel `near` next to it that
// does and the pixel beyond that on the same line (`far`, if it sees the tool). Where the
// thickness falls linearly to 0 before the pixel (two faces meeting at the silhouette, as a box
// seen obliquely), both are extended along the line: the outline then lies where the faces meet,
// to within the float rounding, not to a pixel. Otherwise (a wall seen edge-on, a curved rim) the
// outline is taken half-way, as the nearest pixel would have it, and the back is near's.
vec2 beyond_outline(vec2 near, bool far_seen, vec2 far) {
    float gain = far.y - near.y;  // thickness gained one pixel inwards
    if (far_seen && gain > 0.0 && near.y < gain) return 2.0 * near - far;
    return vec2(near.x, -abs(near.y));
}

#if EXIT
// The back along a line of six pixels (at -2 .. 3: v[0] .. v[5]) at t in [0, 1] between v[2] and
// v[3]: where the back's slopes either side of the middle turn the same way, and the two pixels
// beyond each side continue that side's slope (to KINK_STRAIGHT of the turn: each side is a
// flat face; a curve turns at every pixel), one face of the tool's back gives way to another
// between the middle two (as at a box's edge seen from inside its outline): the line of the side
// t lies on, up to where the two side lines cross, exact where the line through the middle two
// cuts the corner. True then, with `back`; false elsewhere.
bool across(float v[6], float t, out float back) {
    float outer_left = v[1] - v[0], left = v[2] - v[1], mid = v[3] - v[2];
    float right = v[4] - v[3], outer_right = v[5] - v[4];
    float turn = left - right;
    bool kink = (left - mid) * (mid - right) > 0.0 &&
                abs(outer_left - left) <= KINK_STRAIGHT * abs(turn) &&
                abs(outer_right - right) <= KINK_STRAIGHT * abs(turn);
    float cross = kink ? (mid - right) / turn : 0.0;
    back = t < cross ? v[2] + left * t : v[3] - right * (1.0 - t);
    return kink;
}

// Pixel (i, j) of tool_at's block, i and j in -2 .. 3 from floor(p): its index.
int cell(int i, int j) {
    return (i + 2) + 6 * (j + 2);
}

// One row (step 1) or column (step 6) of the 4 x 4 pixels around p from cell `first` at t along
// it: (back, thickness) by the line through its middle two; true where they see the tool;
// `unseen`: neither does.
bool line_at(vec2 block[36], bool seen[36], int first, int step, float t, out vec2 tool,
             out bool unseen) {
    int b = first + step, c = first + 2 * step;
    unseen = !seen[b] && !seen[c];
    tool = mix(block[b], block[c], t);
    return seen[b] && seen[c];
}

// Where the outline runs between the middle two of four lines (rows or columns, `line` at p),
// one seeing the tool and the other not: the one without takes beyond_outline's values from the
// one with and the line beyond that, and the two are blended at t. False elsewhere.
bool between(vec2 line[4], bool seen[4], bool unseen[4], float t, out vec2 tool) {
    tool = vec2(0.0);
    if (seen[1] && unseen[2]) {
        tool = mix(line[1], beyond_outline(line[1], seen[0], line[0]), t);
        return true;
    }
    if (seen[2] && unseen[1]) {
        tool = mix(beyond_outline(line[2], seen[3], line[3]), line[2], t);
        return true;
    }
    return false;
}

// The tool at continuous pixel position p: (back, thickness), false where none of the four pixels
// around p sees it; from the pixels around p, fetched (no filter's rounding: the same values in
// any atlas tile): the 4 x 4 around it and the middle two rows and columns out to six.
// - Where the four around p see the tool: their blend, except where across() finds an edge
//   between two faces of the back between the middle two pixels of either middle row (then
//   those rows at p's column, blended along the column) or column (likewise), or both (the mean).
// - At the outline (some of the four see it, not all): where it runs between two rows or two
//   columns of the four, along those (between(), the rows at p's column by across() where it
//   finds an edge); elsewhere each of the four without the tool takes beyond_outline's values
//   from its neighbours along its row and its column (their mean), or along the diagonal where
//   neither of those sees the tool, and the four are blended. A thickness <= 0 is outside.
bool tool_at(vec2 p, out float back, out float thickness) {
    ivec2 origin = ivec2(floor(p));
    vec2 f = p - floor(p);
    vec2 block[36];
    bool seen[36];
    for (int j = -2; j <= 3; ++j) {
        for (int i = -2; i <= 3; ++i) {
            int k = cell(i, j);
            bool used = (i >= -1 && i <= 2 && j >= -1 && j <= 2) || (i >= 0 && i <= 1) ||
                        (j >= 0 && j <= 1);
            block[k] = vec2(NO_TOOL, 0.0);
            seen[k] = used && tool_pixel(origin + ivec2(i, j), block[k]);
        }
    }
    back = NO_TOOL;
    thickness = INSIDE_OUTLINE;
    // The middle two rows at p's column and columns at p's row: the line, or an edge's sides.
    vec2 row_back, column_back;  // (j = 0, 1), (i = 0, 1)
    bool row_edge = false, column_edge = false;
    for (int m = 0; m <= 1; ++m) {
        float row[6], column[6];
        bool row_whole = true, column_whole = true;
        for (int n = 0; n < 6; ++n) {
            row[n] = block[cell(n - 2, m)].x;
            column[n] = block[cell(m, n - 2)].x;
            row_whole = row_whole && seen[cell(n - 2, m)];
            column_whole = column_whole && seen[cell(m, n - 2)];
        }
        float kinked;
        bool edge = row_whole && across(row, f.x, kinked);
        row_back[m] = edge ? kinked : mix(row[2], row[3], f.x);
        row_edge = row_edge || edge;
        edge = column_whole && across(column, f.y, kinked);
        column_back[m] = edge ? kinked : mix(column[2], column[3], f.y);
        column_edge = column_edge || edge;
    }
    vec2 row[4], column[4];  // (back, thickness) of each row at p's column, each column at p's row
    bool row_seen[4], row_unseen[4], column_seen[4], column_unseen[4];  // their middle two
    for (int j = 0; j < 4; ++j) {
        row_seen[j] = line_at(block, seen, cell(-1, j - 1), 1, f.x, row[j], row_unseen[j]);
        column_seen[j] = line_at(block, seen, cell(j - 1, -1), 6, f.y, column[j], column_unseen[j]);
    }
    row[1].x = row_back[0];
    row[2].x = row_back[1];
    if (row_seen[1] && row_seen[2]) {  // the four around p see the tool
        float by_rows = mix(row_back[0], row_back[1], f.y);
        float by_columns = mix(column_back[0], column_back[1], f.x);
        back = row_edge && column_edge ? 0.5 * (by_rows + by_columns)
                                       : (column_edge ? by_columns : by_rows);
        return true;
    }
    column[1].x = column_back[0];
    column[2].x = column_back[1];
    vec2 tool;
    if (between(row, row_seen, row_unseen, f.y, tool) ||
        between(column, column_seen, column_unseen, f.x, tool)) {
        back = tool.x;
        thickness = tool.y;
        return true;
    }
    vec2 value[4];  // the four around p; some see the tool, not all
    int seen_around = 0;
    for (int k = 0; k < 4; ++k) {
        ivec2 corner = ivec2(k & 1, k >> 1);
        int at = cell(corner.x, corner.y);
        value[k] = block[at];
        if (seen[at]) {
            ++seen_around;
            continue;
        }
        vec2 sum = vec2(0.0);
        float count = 0.0;
        for (int axis = 1; axis <= 3; ++axis) {  // its row, its column; then the diagonal
            int j = k ^ axis;
            ivec2 near = ivec2(j & 1, j >> 1);
            ivec2 far = 2 * near - corner;
            int n = cell(near.x, near.y), m = cell(far.x, far.y);
            if (!seen[n] || (axis == 3 && count > 0.0)) continue;
            sum += beyond_outline(block[n], seen[m], block[m]);
            count += 1.0;
        }
        if (count > 0.0) value[k] = sum / count;
    }
    if (seen_around == 0) return false;
    tool = mix(mix(value[0], value[1], f.x), mix(value[2], value[3], f.x), f.y);
    back = tool.x;
    thickness = tool.y;
    return true;
}
#else
// The tool at continuous pixel position p: its back, false where the pixels around p do not see
// it (thickness INSIDE_OUTLINE: no outline is worked out). Where all four see the tool, the
// sampler blends them (LINEAR: their filtered coverage is 1; pixels without the tool hold 0 in
// both channels, so back / coverage is the blend of those that have it), p rounded to
// 1/TOOL_SUBPIXELS of a pixel first (the filter's own weight precision): with the atlas a power
// of two wide and high, the sampler then sees the same offset from the four pixels wherever the
// camera's tile lies, so a hit gives the same bits in any tile. Elsewhere the nearest pixel's:
// pressed square-on (EXIT 0: no texel's normal leaves the view line), the outline falls between
// pixels only where a wall of the tool is seen edge-on, where the nearest pixel is as good, and
// a software rasteriser, which runs both sides of a branch, is spared EXIT 1's look-ups.
bool tool_at(vec2 p, out float back, out float thickness) {
    ivec2 base = ivec2(floor(p));
    thickness = INSIDE_OUTLINE;
    if (all(greaterThanEqual(base, ivec2(0))) && all(lessThan(base + 1, u_resolution))) {
        vec2 q = floor(p * TOOL_SUBPIXELS + 0.5) / TOOL_SUBPIXELS;
        vec2 at = (q + 0.5 + vec2(u_tile)) / vec2(textureSize(u_tool_depth, 0));
        vec2 tool = texture(u_tool_depth, at).rg;
        if (tool.g >= FULL_COVERAGE) {
            back = tool.r / tool.g;
            return true;
        }
    }
    vec2 tool;
    bool seen = tool_pixel(ivec2(floor(p + 0.5)), tool);
    back = tool.x;
    return seen;
}
#endif

// How far outside the swept solid (metres along the view; < 0 inside) the texel's point lies once
// moved `a` metres inwards along its normal: the larger of its depth past the tool's back and
// how far its view line lies outside the tool's outline (the thickness there, negated). False
// where no pixel around it sees the tool, off the camera too: out, by an unknown margin.
bool beyond(vec3 rel, vec3 n, float depth, float stretch, float a, out float f) {
    float back, thickness;
    f = 0.0;
    if (!tool_at(camera_pixel(rel - n * a), back, thickness)) return false;
    f = max(depth + a / stretch - back, -thickness);
    return true;
}

// An inward distance (metres) at which the moved point is out of the swept solid for certain:
// past the camera's depth range (which holds the whole tool), or a pixel off its rectangle.
float exit_bound(vec3 rel, vec3 n, float depth, float stretch) {
    float bound = (u_depth_range.y - depth) * stretch;
    vec2 at = vec2(dot(rel, u_right), dot(rel, u_up));
    vec2 drift = -vec2(dot(n, u_right), dot(n, u_up));  // camera metres per metre inwards
    vec2 reach = u_half_extent * (1.0 + 2.0 / vec2(u_resolution));
    for (int i = 0; i < 2; ++i) {
        if (abs(drift[i]) > 1e-6) {
            bound = min(bound, (sign(drift[i]) * reach[i] - at[i]) / drift[i]);
        }
    }
    return max(bound, 0.0);
}

// The inward distance a (metres) at which the texel's point leaves the swept solid. `f0` < 0: how
// far inside it the point itself lies (beyond's measure); `a0` > 0: the view-line estimate. A
// march from a0 (doubling, or twice the secant's step where that is longer, up to four times)
// brackets the exit between a point inside (lo) and one out of the solid (hi) in at most
// EXIT_MARCH look-ups, the last at exit_bound; false position with the Illinois step then narrows
// the bracket (bisection while hi has no measure, or after a step that did not halve it), at most
// EXIT_STEPS look-ups, and the root of the last bracket is the answer.
float normal_exit(vec3 rel, vec3 n, float depth, float stretch, float f0, float a0) {
    float far = exit_bound(rel, n, depth, stretch);
    float lo = 0.0, f_lo = f0;
    float hi = min(a0, far), f_hi;
    bool on_hi = beyond(rel, n, depth, stretch, hi, f_hi);
    if (on_hi && abs(f_hi) <= EXIT_SETTLED_METRES) return hi;  // the tool's back is flat here
    for (int k = 0; k < EXIT_MARCH && on_hi && f_hi < 0.0; ++k) {  // still inside: look further
        float next = 2.0 * hi;
        if (f_hi > f_lo) next = clamp(hi - 2.0 * f_hi * (hi - lo) / (f_hi - f_lo), next, 4.0 * hi);
        next = k == EXIT_MARCH - 1 ? far : min(next, far);
        lo = hi;
        f_lo = f_hi;
        hi = next;
        on_hi = beyond(rel, n, depth, stretch, hi, f_hi);
    }
    if (on_hi && f_hi < 0.0) return hi;  // inside at the bound (the depth range misses the tool)
    int kept = 0;  // the end the last step kept: 1 hi, -1 lo (Illinois: halve it if kept twice)
    float width = 2.0 * (hi - lo);  // the bracket's width before the last step
    for (int k = 0; k < EXIT_STEPS; ++k) {
        // A step that did not halve the bracket (a plateau: the point moving along a face of
        // the tool) is followed by a bisection, so the bracket halves at least every two steps.
        bool halve = !on_hi || hi - lo > 0.5 * width;
        width = hi - lo;
        float a = halve ? 0.5 * (lo + hi) : (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
        float f;
        bool on = beyond(rel, n, depth, stretch, a, f);
        if (on && abs(f) <= EXIT_SETTLED_METRES) return a;
        if (on && f < 0.0) {
            lo = a;
            f_lo = f;
            if (kept == 1) f_hi *= 0.5;
            kept = 1;
        } else {
            hi = a;
            f_hi = f;
            on_hi = on;
            if (kept == -1) f_lo *= 0.5;
            kept = -1;
        }
    }
    return on_hi ? (lo * f_hi - hi * f_lo) / (f_hi - f_lo) : 0.5 * (lo + hi);
}
