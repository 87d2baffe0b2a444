#version 330 core
// The charts' coverage (for the chart mask): a mesh's triangles drawn at their texture coordinates.
in vec2 in_uv;
void main() { gl_Position = vec4(in_uv * 2.0 - 1.0, 0.0, 1.0); }
