// Per-frame uniforms shared by the scene shaders. World space, metres.
uniform mat4 u_view_proj;        // clip from world
uniform mat4 u_light_view_proj;  // light clip from world (the shadow map's camera)
uniform vec3 u_camera_pos;       // world
uniform vec3 u_light_dir;        // unit, the way the light travels
uniform vec3 u_light_colour;     // linear RGB times intensity
uniform float u_ambient;         // ambient fraction of the light
