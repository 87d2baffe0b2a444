// What a body's vertex hands lit.frag: world position, texture address, tangent frame and the
// sun's clip position of a mesh point (local metres) moved `height` metres along its normal.
// The frame stays the mesh's: the normal map holds the dent's normals (DISPLACE: see lit.vert).
// Needs frame.glsl.
uniform mat4 u_model;          // world from local
uniform mat3 u_normal_matrix;  // world from local, for normals

out vec3 v_world;
out vec2 v_uv;
out vec3 v_normal;
out vec3 v_tangent;
out vec3 v_bitangent;
out vec4 v_light_clip;
out vec2 v_texture_uv;
#if DISPLACE
out float v_displaced_depth;  // metres the surface was moved inwards (parallax marches the rest)
#endif

void emit_surface(vec3 position, vec3 normal, vec2 uv, vec4 tangent, vec2 texture_uv,
                  float height) {
#if DISPLACE
    position += normalize(normal) * height;
    v_displaced_depth = -height;
#endif
    vec4 world = u_model * vec4(position, 1.0);
    v_world = world.xyz;
    v_uv = uv;
    v_normal = normalize(u_normal_matrix * normal);
    v_tangent = normalize(mat3(u_model) * tangent.xyz);
    v_bitangent = cross(v_normal, v_tangent) * tangent.w;
    v_light_clip = u_light_view_proj * world;
    v_texture_uv = texture_uv;
    gl_Position = u_view_proj * world;
}
