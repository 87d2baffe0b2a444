// Equirectangular directions: u = azimuth / 2 pi (0 along +X, towards +Z at 0.25), v = elevation
// from -pi/2 (v = 0, straight down) to +pi/2 (v = 1, straight up). World space, +Y up.
const float PI = 3.14159265358979;

vec3 equirect_dir(vec2 uv) {
    float phi = uv.x * 2.0 * PI, theta = (uv.y - 0.5) * PI;
    return vec3(cos(theta) * cos(phi), sin(theta), cos(theta) * sin(phi));
}

vec2 equirect_uv(vec3 d) {
    float phi = atan(d.z, d.x);
    return vec2(fract(phi / (2.0 * PI)), asin(clamp(d.y, -1.0, 1.0)) / PI + 0.5);
}
