// The height view's colour ramp: dent depth in millimetres over a fixed range, the same for every
// body, so that the legend (render/legend.py, which evaluates the same stops) reads in mm.
// Stops: 0 = pale grey (untouched), then blue, teal, yellow, red at the full range.
const int RAMP_STOPS = 5;
const vec3 RAMP[5] = vec3[5](vec3(0.88, 0.88, 0.88), vec3(0.20, 0.40, 0.85),
                             vec3(0.10, 0.70, 0.60), vec3(0.95, 0.85, 0.20), vec3(0.85, 0.15, 0.10));

vec3 depth_ramp(float t) {  // t in [0, 1]; sRGB colour
    float x = clamp(t, 0.0, 1.0) * float(RAMP_STOPS - 1);
    int i = min(int(floor(x)), RAMP_STOPS - 2);
    return mix(RAMP[i], RAMP[i + 1], x - float(i));
}
