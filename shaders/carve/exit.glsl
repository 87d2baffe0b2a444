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
// to within the float rounding, not to a pixel; the back no deeper than near's (where the line
// runs over an edge of the back, as at a corner of the outline, it would overshoot). Otherwise
// (a wall seen edge-on, a curved rim, or a pixel without a front face: its thickness is
// INSIDE_OUTLINE, not a length) the outline is taken half-way, as the nearest pixel would have
// it, and the back is near's.
vec2 beyond_outline(vec2 near, bool far_seen, vec2 far) {
    float gain = far.y - near.y;  // thickness gained one pixel inwards
    bool fronts = max(near.y, far.y) < 0.5 * INSIDE_OUTLINE;  // both have a front face
    if (far_seen && fronts && gain > 0.0 && near.y < gain) {
        return vec2(min(2.0 * near.x - far.x, near.x), 2.0 * near.y - far.y);
    }
    return vec2(near.x, -abs(near.y));
}

// The tool at continuous pixel position p: (back, thickness), false where none of the four pixels
// around p sees it. Where all four see it, the sampler blends them (LINEAR: their filtered
// coverage is 1; pixels without the tool hold 0 in both channels, so back / coverage is the blend
// of those that have it), p rounded to 1/TOOL_SUBPIXELS of a pixel first (the filter's own weight
// precision): with the atlas a power of two wide and high, the sampler then sees the same offset
// from the four pixels wherever the camera's tile lies, so a hit gives the same bits in any tile.
// At the outline (EXIT 1; EXIT 0 takes the nearest pixel) each pixel without the tool takes the
// least back and the least thickness beyond_outline gives from its neighbours along its row and
// its column (at a corner of the outline: the nearer face and the tighter outline, never past
// the solid), or along the diagonal where neither of those sees the tool, and the four are
// blended by p's own offset (no rounding: fetched, not filtered); a thickness <= 0 is outside.
bool tool_at(vec2 p, out float back, out float thickness) {
    ivec2 base = ivec2(floor(p));
    vec2 q = floor(p * TOOL_SUBPIXELS + 0.5) / TOOL_SUBPIXELS;
    back = NO_TOOL;
    thickness = INSIDE_OUTLINE;
    if (all(greaterThanEqual(base, ivec2(0))) && all(lessThan(base + 1, u_resolution))) {
        vec2 at = (q + 0.5 + vec2(u_tile)) / vec2(textureSize(u_tool_depth, 0));
        vec2 tool = texture(u_tool_depth, at).rg;
        if (tool.g >= FULL_COVERAGE) {
            back = tool.r / tool.g;
            return true;
        }
    }
#if EXIT
    vec2 corner[4];
    bool seen[4];
    bool any_seen = false;
    for (int k = 0; k < 4; ++k) {
        seen[k] = tool_pixel(base + ivec2(k & 1, k >> 1), corner[k]);
        any_seen = any_seen || seen[k];
    }
    if (!any_seen) return false;
    vec2 value[4];
    for (int k = 0; k < 4; ++k) {
        value[k] = corner[k];
        if (seen[k]) continue;
        vec2 least = vec2(INSIDE_OUTLINE);
        bool found = false;
        for (int axis = 1; axis <= 3; ++axis) {  // its row, its column; then the diagonal
            int j = k ^ axis;
            if (!seen[j] || (axis == 3 && found)) continue;
            ivec2 near = base + ivec2(j & 1, j >> 1);
            vec2 far;
            bool far_seen = tool_pixel(2 * near - base - ivec2(k & 1, k >> 1), far);
            least = min(least, beyond_outline(corner[j], far_seen, far));
            found = true;
        }
        value[k] = least;
    }
    vec2 f = p - vec2(base);  // the pixels' own values, not the sampler's: no rounding
    vec2 tool = mix(mix(value[0], value[1], f.x), mix(value[2], value[3], f.x), f.y);
    back = tool.x;
    thickness = tool.y;
    return true;
#else
    // Pressed square-on (no texel's normal leaves the view line), the outline falls between
    // pixels only where a wall of the tool is seen edge-on: the nearest pixel's is as good, and
    // a software rasteriser, which runs both sides of a branch, is spared the search above.
    vec2 tool;
    bool seen = tool_pixel(ivec2(floor(p + 0.5)), tool);
    back = tool.x;
    return seen;
#endif
}

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
// far inside it the point itself lies (beyond's measure); `start` > 0 (metres), where the search
// first looks: the press's advance. Every distance the search looks at is fixed before it looks
// at the tool: from `start` (or the bound exit_bound, if nearer), a march by factors of two,
// outwards while the point is inside, inwards while it is out (not below EXIT_FIRST_METRES, then
// 0 is the inner end), brackets an exit between a point inside (lo) and one out of the solid
// (hi) in at most EXIT_MARCH look-ups, the last outwards at exit_bound; EXIT_STEPS bisections
// narrow the bracket, and the root of the line through its ends is the answer. So a smaller tool
// never answers farther (monotone): each look-up that finds it inside finds the larger tool
// inside too, so its bracket is the same or nearer. The same press again, whose tool the first
// press dented (both directions read the heights from before the hit: the first tool less its
// dent), writes no texel deeper, and MIN keeps every bit. (False position from the view-line
// estimate looked at distances that depend on the tool, and its repeat deepened a mesh by up to
// a few micrometres.) Starting at the advance rather than at EXIT_FIRST_METRES saves most of
// the march: most texels of a dent leave the solid within a factor of two of it.
float normal_exit(vec3 rel, vec3 n, float depth, float stretch, float f0, float start) {
    float far = exit_bound(rel, n, depth, stretch);
    float lo = 0.0, f_lo = f0;
    float hi = min(start, far), f_hi;
    bool on_hi = beyond(rel, n, depth, stretch, hi, f_hi);
    // The march outwards (OUTWARDS), inwards (INWARDS) and the bisections (BISECT) are phases of
    // one loop, one look-up a turn: a software rasteriser runs each loop until its last fragment
    // is done, and both sides of an if, so three loops would cost each fragment the longest of
    // each; one costs it the longest whole search. Each fragment looks at the distances it would
    // in three loops, in the same order.
    const int OUTWARDS = 0, INWARDS = 1, BISECT = 2;
    int phase = on_hi && f_hi < 0.0 ? OUTWARDS : INWARDS;  // inside: look further; out: nearer
    int march = 0, steps = 0;
    for (int turn = 0; turn < EXIT_MARCH + EXIT_STEPS; ++turn) {
        if (phase == INWARDS && !(march < EXIT_MARCH && hi > EXIT_FIRST_METRES)) phase = BISECT;
        if (phase == BISECT && steps >= EXIT_STEPS) break;
        float a = phase == BISECT ? 0.5 * (lo + hi)
                : phase == INWARDS ? 0.5 * hi
                : march == EXIT_MARCH - 1 ? far : min(2.0 * hi, far);
        float f;
        bool on = beyond(rel, n, depth, stretch, a, f);
        bool inside = on && f < 0.0;
        if (phase == OUTWARDS) {  // the bracket's inner end moves out to its outer end
            ++march;
            lo = hi;
            f_lo = f_hi;
            if (!inside) phase = BISECT;
            else if (march == EXIT_MARCH) return a;  // inside at the bound (depth range misses it)
        } else if (phase == INWARDS) {
            ++march;
            if (inside) phase = BISECT;
        } else {
            ++steps;
        }
        if (inside && phase != OUTWARDS) {
            lo = a;
            f_lo = f;
        } else {
            hi = a;
            f_hi = f;
            on_hi = on;
        }
    }
    // The line's root lo + (hi - lo) x / (x + y), x = -f_lo > 0, y = f_hi >= 0, written so that
    // each operation rounds monotonically: nearer where either end lies farther out. Where hi has
    // no measure (off the tool), the middle.
    return on_hi ? lo + (hi - lo) / (1.0 + f_hi / -f_lo) : 0.5 * (lo + hi);
}
