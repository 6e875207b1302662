// Display encoding: the piecewise sRGB OETF (IEC 61966-2-1), not pow(1/2.2).
vec3 srgb_oetf(vec3 linear) {
    vec3 x = saturate(linear);
    return mix(12.92 * x, 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), x));
}
