#version 330 core
// One triangle that covers the viewport; v_texel is unused by whole-map passes.
flat out ivec2 v_texel;
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    v_texel = ivec2(-1);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
