// Image-based lighting from the baked environment: GGX-prefiltered cubemap (roughness -> lod
// linear, lod = r (levels - 1), the inverse of the bake), SH9 irradiance, DFG split sum
// (IBL_METHOD split_sum), or the per-pixel sampled specular of ibl_sampled.glsl (sampled).
#include "lobe_read.glsl"

uniform samplerCube u_prefiltered;
uniform float u_prefiltered_lods;   // number of mip levels - 1
uniform vec3 u_sh[9];               // irradiance SH9, cosine lobe already applied
uniform vec3 u_floor_irradiance_over_pi;   // E / pi of an upward normal, summed exactly (sh_main.glsl)

// Between levels 0 (a mirror) and 1 (r = 1 / lods) the read blends the two by the lobe's second
// moment, alpha^2 ~ x^4, not linearly in x: the linear blend put 20 % of the r = 0.2 lobe into
// an r = 0.045 one, a halo around every sharp reflection (the default chart's polished metal
// 0.071 -> 0.051 mean FLIP). Above level 1 the blend stays linear: the core scale and the lobe
// fits below were made through it (the same remap there took r = 0.25 metals 0.075 -> 0.082).
vec3 prefiltered_radiance(vec3 r_dir, float perceptual_roughness) {
#if STAGE_PROBE
    perceptual_roughness *= sqrt(stage_parallax_narrowing(r_dir, sq(perceptual_roughness)));
    r_dir = stage_parallax(r_dir);
#endif
    float x = max(perceptual_roughness, g_reflection_blur) * u_prefiltered_lods;
    if (x < 1.0) x = sq(sq(x));
    return textureLod(u_prefiltered, r_dir, x).rgb;
}

// The irradiance's SH bands 1 and 2 scaled by band1 and band2: a lobe about d other than the
// cosine's (whose mean cosine is 2/3) weighs them so; never negative.
vec3 sh_irradiance_banded(vec3 d, float band1, float band2) {
    vec3 e = u_sh[0]
           + band1 * (u_sh[1] * d.y + u_sh[2] * d.z + u_sh[3] * d.x)
           + band2 * (u_sh[4] * (d.x * d.y) + u_sh[5] * (d.y * d.z) + u_sh[6] * (3.0 * d.z * d.z - 1.0)
                      + u_sh[7] * (d.x * d.z) + u_sh[8] * (d.x * d.x - d.y * d.y));
    return max(e, vec3(0.0));
}

// Irradiance E(n) = integral of L cos (Ramamoorthi & Hanrahan 2001), never negative.
vec3 sh_irradiance(vec3 n) {
    return sh_irradiance_banded(n, 1.0, 1.0);
}

// Where and how wide the split sum reads the prefiltered map (IBL_DOMINANT_DIR):
// - none: along R at the material's roughness, the split sum's assumption V = N = R;
// - frostbite: R leaned toward N as the lobe widens (GGX lobes seen off-normal peak between
//   R and N), Lagarde & de Rousiers 2014, "Moving Frostbite to PBR", listing 22:
//   lerp(N, R, (1 - a)(sqrt(1 - a) + a)), a = alpha;
// - moments: fitted to this BRDF: the direction of the centroid of f cos (F = 1) of the
//   height-correlated GGX lobe, as lerp(N, R, t(NdotV, a)), and the roughness whose V = N
//   prefilter kernel (PREFILTER_KERNEL brdf, the split sum's) has the same centroid length
//   (mean cosine), r_eff(NdotV, a): seen off-normal the lobe is stretched and wider. Both are
//   polynomials, degree 3 in NdotV and in a, least-squares fitted to float64 moments of
//   sdfpbr.oracle.ibl_integral on NdotV 0.1..1, r 0.1..1 (max error 0.021 in t; 0.05 in r_eff,
//   where it passes 1 and the chain clamps it anyway).
struct SpecularLookup { vec3 direction; float perceptual_roughness; };
#define TAIL_MAX 0.22
#define TAIL_SLOPE 0.55       // the one-read ramps: tail = SLOPE (r - FROM), to TAIL_MAX ...
#define TAIL_FROM 0.27
#define CORE_SCALE 0.87
#define CORE_FULL_FROM 0.8    // ... and a core scaled by CORE_SCALE, to 1 over r FULL_FROM .. 1
#define LOBE_TAP_FADE 0.05   // sin(3 degrees): the two taps' offset fades out within it of N

#if IBL_DOMINANT_DIR == moments
float poly3(vec4 c, float x) { return c.x + x * (c.y + x * (c.z + x * c.w)); }

// sum over i, j of C[i][j] mu^i a^j: rows are powers of mu, columns powers of a.
float poly3x3(mat4 c, float mu, float a) {
    return poly3(vec4(poly3(c[0], a), poly3(c[1], a), poly3(c[2], a), poly3(c[3], a)), mu);
}

const mat4 LOBE_T = mat4(
    0.99207, -2.81084, 3.84268, -2.04072,
    0.25649, 4.24510, -11.42984, 7.02438,
    -0.48403, -1.44510, 6.75248, -4.94302,
    0.23480, 0.18741, -1.87488, 1.49689);
const mat4 LOBE_DR = mat4(
    0.06398, -0.12727, 0.97403, -0.11894,
    -0.41132, 0.52012, -4.60509, 2.21143,
    0.67447, -2.04185, 9.34162, -5.40672,
    -0.33009, 1.66771, -5.77449, 3.35483);
#endif

SpecularLookup specular_lookup(vec3 n, vec3 v, float n_dot_v, float perceptual_roughness, float alpha) {
    vec3 r_dir = reflect(-v, n);
#if IBL_DOMINANT_DIR == frostbite
    float smooth_ = saturate(1.0 - alpha);
    r_dir = normalize(mix(n, r_dir, smooth_ * (sqrt(smooth_) + alpha)));
#elif IBL_DOMINANT_DIR == moments
    float mu = clamp(n_dot_v, 0.1, 1.0), a = clamp(alpha, 0.01, 1.0);
    r_dir = normalize(mix(n, r_dir, saturate(poly3x3(LOBE_T, mu, a))));
    perceptual_roughness = perceptual_roughness + poly3x3(LOBE_DR, mu, a) * step(0.1, perceptual_roughness);
#endif
    return SpecularLookup(r_dir, perceptual_roughness);
}

// The glTF mix from its lighting terms; each specular lobe compensated with its own f0.
// mean_a, mean_b: the radiance averaged over the specular lobe with the weights of A and of B
// (both the prefiltered radiance in the split sum); irradiance_over_pi: E(n) / pi.
vec3 ibl_mix(Material m, vec3 dfg, vec3 mean_a, vec3 mean_b, vec3 irradiance_over_pi) {
    float e_single = dfg.x + dfg.y;
    vec3 f0 = dielectric_f0(m);
#if KHR_SPECULAR
    // The LUT's C is 1 - (0.04 + 0.96 <Fc>) for f0 = 0.04; the extension's weight is
    // 1 - w (max3(f0) + (1 - max3(f0)) <Fc>), <Fc> the cosine-weighted mean of (1 - V.H)^5.
    float mean_fc = (1.0 - DIELECTRIC_F0 - dfg.z) / (1.0 - DIELECTRIC_F0);
    dfg.z = 1.0 - m.specular_weight * (max3(f0) + (1.0 - max3(f0)) * mean_fc);
    vec3 spec_dielectric = m.specular_weight * (f0 * dfg.x * mean_a + dfg.y * mean_b) * energy_compensation(f0, e_single);
#else
    vec3 spec_dielectric = (f0 * dfg.x * mean_a + dfg.y * mean_b) * energy_compensation(f0, e_single);
#endif
    vec3 metal = (m.base_color_linear * dfg.x * mean_a + dfg.y * mean_b)
               * energy_compensation(m.base_color_linear, e_single);
#if BUG_DIFFUSE_NO_FRESNEL
    vec3 diffuse = m.base_color_linear * irradiance_over_pi;
#else
    vec3 diffuse = m.base_color_linear * irradiance_over_pi * dfg.z;
#endif
#if BUG_METAL_DIFFUSE
    return diffuse + mix(spec_dielectric, metal, m.metallic);
#else
    return mix(diffuse + spec_dielectric, metal, m.metallic);
#endif
}

// Split sum: one prefiltered radiance for the whole lobe, SH9 irradiance for the diffuse.
// IBL_TWO_LOBE: a rough lobe seen off-normal has more of its weight far from its centre (a
// heavy tail towards the horizon) than a V = N kernel of the same mean cosine, so the lookup
// becomes a narrower core plus a share w of the widest level read along N (lobe_fit below). The
// core's scale and w are fits of the float64 lobe average under random three-lobe
// environments, not the test environment: ramps in r, or with IBL_TWO_TAP a table over r and
// N.V (ibl_lobe_table.glsl) with the core read twice along the lobe's stretch.
// The sky's irradiance / pi the spheres' diffuse reads (sampled: the r = 1 level, below).
vec3 ibl_irradiance_over_pi(vec3 n) {
#if IBL_METHOD == sampled
    return textureLod(u_prefiltered, n, u_prefiltered_lods).rgb;
#else
    return sh_irradiance(n) * INV_PI;
#endif
}

// The diffuse part of a sphere's IBL (the rest of shade_ibl's sum is its specular).
vec3 ibl_diffuse(Material m, vec3 dfg, vec3 n) {
    return ibl_mix(m, dfg, vec3(0.0), vec3(0.0), ibl_irradiance_over_pi(n));
}

// How the split sum reads a lobe: the share ``tail`` read along N at the widest level, the
// core's width (core_scale x the lookup's roughness) and, IBL_TWO_TAP, the offset ``delta`` of
// the core's two reads either side of its direction in the plane of N and R (a rough lobe seen
// off-normal is stretched in that plane). Without IBL_TWO_LOBE one read of the whole lobe.
struct LobeFit { float tail; float core_scale; float delta; };

#if IBL_TWO_TAP
#include "ibl_lobe_table.glsl"
#endif

LobeFit lobe_fit(float perceptual_roughness, float n_dot_v) {
#if IBL_TWO_TAP
    // The table from r = 0.2 up; below it the one-read ramps' values (no tail, CORE_SCALE),
    // blended in over r 0.1 .. 0.2 so the polished spheres read as before.
    LobeFit fit = lobe_table(perceptual_roughness, n_dot_v);
    float t = smoothstep(0.1, 0.2, perceptual_roughness);
    return LobeFit(fit.tail * t, mix(CORE_SCALE, fit.core_scale, t), fit.delta * t);
#elif IBL_TWO_LOBE
    return LobeFit(clamp(TAIL_SLOPE * (perceptual_roughness - TAIL_FROM), 0.0, TAIL_MAX),
                   mix(CORE_SCALE, 1.0, smoothstep(CORE_FULL_FROM, 1.0, perceptual_roughness)), 0.0);
#else
    return LobeFit(0.0, 1.0, 0.0);
#endif
}

vec3 shade_ibl(Material m, vec3 n, vec3 v, float n_dot_v, vec3 dfg) {
    SpecularLookup look = specular_lookup(n, v, n_dot_v, m.perceptual_roughness, m.alpha);
#if IBL_TWO_LOBE
    LobeFit fit = lobe_fit(m.perceptual_roughness, n_dot_v);
    float core_roughness = look.perceptual_roughness * fit.core_scale;
#if IBL_TWO_TAP
    // In the plane of N and R; where the direction nears N (N.V -> 1) that plane is lost to
    // rounding and the lobe is not stretched, so the offset fades out within 3 degrees of N.
    vec3 across = n - look.direction * dot(n, look.direction);
    across *= fit.delta / max(length(across), LOBE_TAP_FADE);
    vec3 core = 0.5 * (prefiltered_radiance(normalize(look.direction + across), core_roughness)
                     + prefiltered_radiance(normalize(look.direction - across), core_roughness));
#else
    vec3 core = prefiltered_radiance(look.direction, core_roughness);
#endif
    vec3 radiance = mix(core, textureLod(u_prefiltered, n, u_prefiltered_lods).rgb, fit.tail);
#else
    vec3 radiance = prefiltered_radiance(look.direction, look.perceptual_roughness);
#endif
    return ibl_mix(m, dfg, radiance, radiance, sh_irradiance(n) * INV_PI);
}

#if IBL_METHOD == sampled
#include "ibl_sampled.glsl"

// Sampled (the spheres of the high preset): the lobe-weighted mean radiances of
// ibl_sampled.glsl, and the irradiance read from the r = 1 level (see ibl_sampled.glsl).
vec3 shade_ibl_sampled(Material m, vec3 n, vec3 v, float n_dot_v, vec3 dfg) {
    SampledSpecular s = sampled_specular(n, v, n_dot_v, m.alpha);
    return ibl_mix(m, dfg, s.mean_a, s.mean_b, ibl_irradiance_over_pi(n));
}
#endif
