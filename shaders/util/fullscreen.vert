#version 330 core
// One triangle that covers the viewport; v_texel is unused by whole-map passes. AT_FAR_PLANE puts
// it at depth 1 (the sky, drawn last behind the depth-tested bodies).
flat out ivec2 v_texel;
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    v_texel = ivec2(-1);
#ifdef AT_FAR_PLANE
    gl_Position = vec4(p * 2.0 - 1.0, 1.0, 1.0);  // depth 1: only where nothing was drawn
#else
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
#endif
}
