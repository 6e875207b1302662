// Tone mappers on linear RGB. TONEMAP picks one at compose time: each tone mapper of
// spec/presets.py TONE_MAPPERS has a branch in tonemap() below, and a float64 twin in
// oracle/display.py (tonemap_<its GLSL word>).
uniform float u_reinhard_white;
#define TONEMAP_INPUT_MAX 1e4

// Narkowicz's fit of the ACES filmic curve, per channel.
vec3 tonemap_aces(vec3 x) {
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

// AgX (Sobotka; Blender's base look): to Rec. 2020 and inset toward white, log2 from 0.18 x 2^-10
// to 0.18 x 2^6.5, the polynomial fit of AgX's sigmoid, outset, its 2.2 power undone, back to
// sRGB primaries. The matrices (column by column) are products oracle/display.py builds from the
// published inset and outset and the primaries; its tonemap_agx is this function in float64.
vec3 tonemap_agx(vec3 x) {
    const mat3 srgb_to_inset = mat3(0.5448147465, 0.1404169485, 0.08881041961,
                                    0.3737873984, 0.7541375546, 0.1788717564,
                                    0.08139785514, 0.105445497, 0.732317824);
    const mat3 outset = mat3( 1.127100582, -0.1413297635, -0.1413297635,
                             -0.1106066431, 1.157823702, -0.1106066431,
                             -0.01649393872, -0.01649393872, 1.251936407);
    const mat3 rec2020_to_srgb = mat3( 1.660491002, -0.1245504745, -0.01815076335,
                                      -0.5876411388, 1.132899897, -0.100578898,
                                      -0.07284986332, -0.008349422604, 1.118729661);
    const float min_ev = -12.47393119;   // log2(0.18) - 10
    const float max_ev = 4.026068812;    // log2(0.18) + 6.5
    vec3 c = srgb_to_inset * max(x, 0.0);
    c = saturate((log2(max(c, 1e-10)) - min_ev) / (max_ev - min_ev));
    // Horner's form: near 1 the terms (up to ~40) cancel to ~1; summed as powers they cost
    // float32 3x the error (1.2e-5 of the sRGB output against the float64 curve, here 4e-6).
    c = (((((15.5 * c - 40.14) * c + 31.96) * c - 6.868) * c + 0.4298) * c + 0.1191) * c - 0.00232;
    c = pow(max(outset * c, 0.0), vec3(2.2));
    return saturate(rec2020_to_srgb * c);
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
    return tonemap_aces(x);
#elif TONEMAP == aces_hill
    return tonemap_aces_hill(x);
#elif TONEMAP == neutral
    return tonemap_neutral(x);
#elif TONEMAP == agx
    return tonemap_agx(x);
#endif
}
