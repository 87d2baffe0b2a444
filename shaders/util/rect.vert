#version 330 core
// A rectangle in pixels (for overlays; the carve's texel rectangles, RECT 1), drawn as a triangle
// strip of 4 vertices.
uniform vec4 u_rect;      // x, y, width, height in pixels
uniform vec2 u_viewport;  // pixels
#ifdef CLIP_DISTANCES  // drawn under a state that enables this many clip distances: none clips
out float gl_ClipDistance[CLIP_DISTANCES];
#endif
void main() {
    vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);
    vec2 pixel = u_rect.xy + corner * u_rect.zw;
    gl_Position = vec4(pixel / u_viewport * 2.0 - 1.0, 0.0, 1.0);
#ifdef CLIP_DISTANCES
    for (int k = 0; k < CLIP_DISTANCES; ++k) gl_ClipDistance[k] = 1.0;
#endif
}
