// Scene-referred linear RGB to display: the ACES filmic curve as fitted by K. Narkowicz (2015),
// then the exact sRGB transfer curve (srgb.glsl). `exposure` scales the scene first.
#include "srgb.glsl"

vec3 tonemap(vec3 c, float exposure) {
    c *= exposure;
    c = (c * (2.51 * c + 0.03)) / (c * (2.43 * c + 0.59) + 0.14);
    return linear_to_srgb(clamp(c, 0.0, 1.0));
}
