// The light around the scene, procedural, linear RGB radiance (the sun's direct light is added
// analytically by the lit shader; here it is only its glow): a sky from horizon haze to zenith
// blue, a dim warm floor, and a studio's surround of large soft light panels whose edges a metal
// dent reflects at a different place than the flat metal around it.
uniform vec3 u_sun_dir;  // unit, the way sunlight travels (world)

float panel(vec3 d, vec3 centre, vec2 half_size, float softness) {
    // A rectangle facing the origin, centred on `centre` (unit), sizes in radians.
    vec3 right = normalize(cross(vec3(0.0, 1.0, 0.0), centre));
    vec3 up = cross(centre, right);
    float facing = dot(d, centre);
    if (facing <= 0.0) return 0.0;
    vec2 p = vec2(dot(d, right), dot(d, up)) / facing;
    vec2 edge = smoothstep(half_size + softness, half_size - softness, abs(p));
    return edge.x * edge.y;
}

vec3 environment(vec3 d) {
    float y = d.y;
    vec3 horizon = vec3(0.80, 0.82, 0.85), zenith = vec3(0.22, 0.38, 0.70);
    vec3 sky = mix(horizon, zenith, pow(clamp(y, 0.0, 1.0), 0.6));
    vec3 floor_colour = vec3(0.30, 0.28, 0.25) * (0.6 + 0.4 * smoothstep(-0.4, 0.0, y));
    vec3 c = y >= 0.0 ? sky : mix(floor_colour, horizon * 0.35, smoothstep(-0.08, 0.0, y));
    // Studio panels: three softboxes and a thin strip, bright against a darker band.
    c *= 1.0 - 0.3 * smoothstep(0.1, 0.3, y) * (1.0 - smoothstep(0.55, 0.8, y));
    c += vec3(3.2, 3.1, 2.9) * panel(d, normalize(vec3(-0.7, 0.45, 0.55)), vec2(0.55, 0.3), 0.05);
    c += vec3(2.0, 2.1, 2.3) * panel(d, normalize(vec3(0.8, 0.35, -0.45)), vec2(0.35, 0.45), 0.05);
    c += vec3(2.5) * panel(d, normalize(vec3(0.1, 0.25, -1.0)), vec2(0.9, 0.05), 0.02);
    c += vec3(2.8, 2.8, 2.7) * panel(d, normalize(vec3(0.0, 0.85, -0.5)), vec2(0.35, 0.15), 0.03);
    // The sun's glow (its disc is the direct light).
    float s = max(dot(d, -u_sun_dir), 0.0);
    c += vec3(1.0, 0.9, 0.75) * (pow(s, 64.0) * 2.0 + pow(s, 8.0) * 0.25);
    return c;
}
