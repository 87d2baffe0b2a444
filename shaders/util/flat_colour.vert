#version 330 core
// A test and debug shader: positions already in clip coordinates, one colour per vertex.
in vec2 in_position;   // clip coordinates
in vec3 in_colour;     // linear RGB
out vec3 v_colour;
void main() {
    v_colour = in_colour;
    gl_Position = vec4(in_position, 0.0, 1.0);
}
