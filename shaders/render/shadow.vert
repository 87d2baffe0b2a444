#version 330 core
// Depth from the light for the shadow map.
#include "frame.glsl"
uniform mat4 u_model;  // world from local
in vec3 in_position;   // local metres
void main() { gl_Position = u_light_view_proj * u_model * vec4(in_position, 1.0); }
