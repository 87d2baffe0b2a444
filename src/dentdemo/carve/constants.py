"""Constants shared by the carve's Python code and its shaders, defined once here and injected into
every carve program as `#define`s (see `shader_defines`)."""

from __future__ import annotations

#: Pass 3's clear value for both its channels, the tool's depth and its coverage: no tool at that
#: camera pixel, so pass 4 changes nothing through it.
NO_TOOL = 0.0
#: Pass 4 takes the sampler's bilinear tool depth only where the four pixels around a texel all
#: see the tool: the filtered coverage is then 1 (this bound leaves room for filter rounding).
FULL_COVERAGE = 0.9999
#: Pass 3's clear value of the tool's nearest depth (alpha, blended MIN): no front face there.
NO_FRONT = 1e30
#: Pass 2 keeps a target surface that lies this far (metres) in front of the tool's first-touch
#: front face at the same pixel: float32 rounding of two depths computed at one pixel centre.
FRONT_TOLERANCE = 1e-6
#: Pass 4 finds how far a texel's point moves inwards along its normal to leave the tool's swept
#: solid at distances fixed before it looks at the tool (so a smaller tool never answers farther:
#: the same press again writes the same bits): a march by factors of two from the press's advance
#: (outwards while the point is inside, inwards down to EXIT_FIRST_METRES while it is out)
#: brackets an exit in at most EXIT_MARCH look-ups of the tool's extent (outwards, the last at a
#: distance where the point is out for certain), then EXIT_STEPS bisections narrow it (to 1/4096)
#: and the line through its ends gives the root. A press along the surface normal needs none.
EXIT_FIRST_METRES = 1e-5
EXIT_MARCH = 19
EXIT_STEPS = 12
#: Pass 4's thickness of the tool (back minus front, metres along the view) where all four camera
#: pixels around a position see it, or where a pixel saw no front face: well inside its outline.
INSIDE_OUTLINE = 1e30
#: Pass 4 rounds a position to this fraction of a camera pixel before the sampler blends the
#: tool's depth there (as fine as the filter's own weights): the same bits in any atlas tile.
TOOL_SUBPIXELS = 256.0
#: Grazing clamp: the depth-to-height stretch 1/cos(normal, press direction) is capped at 1/MIN_COS.
MIN_COS = 0.2
#: A gutter texel (outside every chart) takes a value when its centre lies within this many texels
#: of a triangle in texture space: half a texel's diagonal, i.e. the texel overlaps the triangle.
GUTTER_REACH_TEXELS = 0.7072
#: Pass 4 keeps texels within this many texels (along the press) of the overlap's slab: float
#: rounding never clips a texel that lies on the slab's face.
SLAB_MARGIN_TEXELS = 0.25
#: Pass 5 also rebuilds the texels this many texels beyond pass 4's slab: the neighbours whose
#: central differences read a changed height.
RING_TEXELS = 1.5
#: Entries of a batch's job table (shaders/carve/job.glsl) one uniform-buffer range holds at
#: least: 40 entries of 368 bytes fit GL 3.3's smallest uniform block (16 KiB); a context whose
#: blocks hold more gets more (carve/jobs.py, `job_entries`).
JOB_ENTRIES = 40
#: Triangles a list may hold to be drawn for jobs of which each has some of them
#: (`params.Subset`: a bit each in job.glsl's ivec4 list_skip, so at most 4 x 32).
SUBSET_TRIANGLES = 128
#: Address-map clear value of u: no target surface at that camera pixel.
NO_SURFACE = -1.0
#: The chart mask's bits (R8UI, one byte a texel): the texel itself lies inside a UV chart, then
#: its neighbour at -u, +u, -v, +v does (and lies inside the map).
CHART_SELF, CHART_LEFT, CHART_RIGHT, CHART_DOWN, CHART_UP = 1, 2, 4, 8, 16


def shader_defines(**extra: object) -> dict[str, object]:
    """The carve constants as GLSL `#define`s (floats written so GLSL parses them as floats)."""
    defines: dict[str, object] = {
        "NO_TOOL": repr(float(NO_TOOL)),
        "NO_FRONT": repr(float(NO_FRONT)),
        "FRONT_TOLERANCE": repr(float(FRONT_TOLERANCE)),
        "FULL_COVERAGE": repr(float(FULL_COVERAGE)),
        "MIN_COS": repr(float(MIN_COS)),
        "EXIT_FIRST_METRES": repr(float(EXIT_FIRST_METRES)),
        "EXIT_MARCH": str(EXIT_MARCH),
        "INSIDE_OUTLINE": repr(float(INSIDE_OUTLINE)),
        "EXIT_STEPS": str(EXIT_STEPS),
        "TOOL_SUBPIXELS": repr(float(TOOL_SUBPIXELS)),
        "GUTTER_REACH_TEXELS": repr(float(GUTTER_REACH_TEXELS)),
        "NO_SURFACE": repr(float(NO_SURFACE)),
        "JOB_ENTRIES": str(JOB_ENTRIES),
        "SUBSET_TRIANGLES": str(SUBSET_TRIANGLES),
        **{
            name: f"{value}u"
            for name, value in (
                ("CHART_SELF", CHART_SELF),
                ("CHART_LEFT", CHART_LEFT),
                ("CHART_RIGHT", CHART_RIGHT),
                ("CHART_DOWN", CHART_DOWN),
                ("CHART_UP", CHART_UP),
            )
        },
    }
    defines.update(extra)
    return defines
