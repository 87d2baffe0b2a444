#version 330 core
// Debug lines (contact points and normals), world space.
#include "frame.glsl"
in vec3 in_position;  // world metres
in vec3 in_colour;    // sRGB
out vec3 v_colour;
void main() {
    v_colour = in_colour;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
