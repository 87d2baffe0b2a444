#version 330 core
// Scene bodies: world position, texture address and tangent frame for normal mapping.
#include "frame.glsl"

uniform mat4 u_model;          // world from local
uniform mat3 u_normal_matrix;  // world from local, for normals

in vec3 in_position;  // local metres
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;   // xyz along +u, w = handedness
in vec2 in_texture_uv;  // where the mesh's own base-colour image is sampled

out vec3 v_world;
out vec2 v_uv;
out vec3 v_normal;
out vec3 v_tangent;
out vec3 v_bitangent;
out vec4 v_light_clip;
out vec2 v_texture_uv;

void main() {
    vec4 world = u_model * vec4(in_position, 1.0);
    v_world = world.xyz;
    v_uv = in_uv;
    v_normal = normalize(u_normal_matrix * in_normal);
    v_tangent = normalize(mat3(u_model) * in_tangent.xyz);
    v_bitangent = cross(v_normal, v_tangent) * in_tangent.w;
    v_light_clip = u_light_view_proj * world;
    v_texture_uv = in_texture_uv;
    gl_Position = u_view_proj * world;
}
