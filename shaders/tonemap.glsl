// Tone mappers on linear RGB (REFERENCE.md §4). TONEMAP picks one at compose time.
uniform float u_reinhard_white;
#define TONEMAP_INPUT_MAX 1e4

vec3 tonemap_aces_narkowicz(vec3 x) {
    return saturate(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14));
}

// Stephen Hill's fit of the ACES RRT + ODT. GLSL mat3 is column-major: these are the
// transposes of the row-major published matrices, so that M * c applies them.
vec3 tonemap_aces_hill(vec3 c) {
    const mat3 input_mat = mat3(0.59719, 0.07600, 0.02840,
                                0.35458, 0.90834, 0.13383,
                                0.04823, 0.01566, 0.83777);
    const mat3 output_mat = mat3( 1.60475, -0.10208, -0.00327,
                                 -0.53108,  1.10813, -0.07276,
                                 -0.07367, -0.00605,  1.07602);
    c = input_mat * c;
    c = (c * (c + 0.0245786) - 0.000090537) / (c * (0.983729 * c + 0.4329510) + 0.238081);
    return saturate(output_mat * c);
}

// Khronos PBR Neutral.
vec3 tonemap_neutral(vec3 color) {
    const float start_compression = 0.8 - 0.04;
    const float desaturation = 0.15;
    float x = min(color.r, min(color.g, color.b));
    float offset = x < 0.08 ? x - 6.25 * x * x : 0.04;
    color -= offset;
    float peak = max(color.r, max(color.g, color.b));
    if (peak < start_compression) return color;
    const float d = 1.0 - start_compression;
    float new_peak = 1.0 - d * d / (peak + d - start_compression);
    color *= new_peak / peak;
    float g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0);
    return mix(color, vec3(new_peak), g);
}

vec3 tonemap(vec3 x) {
    // Every curve is display white long before 1e4 (tests/test_precision.py: 0 LSB change),
    // and the ACES fits square x: past ~1e19 that overflowed fp32 and inf / inf turned the
    // brightest highlights black (found by `sdfpbr stress` at the spec's 1e12 / +40 EV).
    x = min(x, vec3(TONEMAP_INPUT_MAX));
#if TONEMAP == none
    return x;
#elif TONEMAP == clamp
    return saturate(x);
#elif TONEMAP == reinhard
    return x / (1.0 + x);
#elif TONEMAP == reinhard_extended
    return x * (1.0 + x / sq(u_reinhard_white)) / (1.0 + x);
#elif TONEMAP == aces
    return tonemap_aces_narkowicz(x);
#elif TONEMAP == aces_hill
    return tonemap_aces_hill(x);
#elif TONEMAP == neutral
    return tonemap_neutral(x);
#endif
}
