// The KHR layers of lobes.glsl under the environment, over the base's IBL:
// sheen: colour x E_s(N.V) x the mean radiance its lobe gathers; the base scaled by the spec's
// exact min(1 - c E_s(N.V), 1 - c E_s(N.L)), averaged over the light each part takes: its
// diffuse over the cosine; its specular, on the sampled path (the high preset), over its GGX
// lobe, else by the spec's simplified form at N.V alone (a rough base's specular 3-9 % bright
// under the furnace: a rough lobe takes light from lower N.L, where E_s is larger; the
// simplified form on the diffuse read it 2-7 % bright at N.V > 0.5). The GGX lobe's rule costs
// 32 lookups a pixel: 2x the draft's lobes chart, for no FLIP measured. The sheen's light: on
// the sampled path integrated per pixel; else (and in the bounce rays) from the SH9 irradiance.
// Its lobe is wide and leans from N towards V and the horizon: with SHEEN_LEAN that irradiance is read along the lobe's mean
// direction c (shading.sheen's float64 table), its first band scaled by |c| over the cosine's
// 2/3 (exact for bands 0 and 1) and its second by the square; else along N, as a cosine lobe;
// clearcoat: the coat's split sum E_c(N_c.V) x the prefiltered radiance along the coat's
// mirror direction at its roughness, mixed over the rest by clearcoat F(N_c.V).
#include "bounce_split.glsl"
#include "lobe_read.glsl"

#if SHEEN
#if SHEEN_LEAN
#define SHEEN_CENTROID_ENTRIES (SHEEN_CENTROID_MU_STEPS * SHEEN_CENTROID_R_STEPS)
uniform vec4 u_sheen_centroid[(SHEEN_CENTROID_ENTRIES + 1) / 2];   // two (c_n, c_t) entries a vec4

vec2 sheen_centroid_entry(int i) {
    vec4 pair = u_sheen_centroid[i / 2];
    return (i % 2 == 0) ? pair.xy : pair.zw;
}

// (c_n, c_t), bilinear over sqrt(1 - N.V) and the sheen roughness.
vec2 sheen_centroid(float n_dot_v, float sheen_perceptual_roughness) {
    float x = sqrt(saturate(1.0 - n_dot_v)) * float(SHEEN_CENTROID_MU_STEPS - 1);
    float y = saturate(sheen_perceptual_roughness) * float(SHEEN_CENTROID_R_STEPS - 1);
    int i = min(int(x), SHEEN_CENTROID_MU_STEPS - 2);
    int j = min(int(y), SHEEN_CENTROID_R_STEPS - 2);
    int k = i * SHEEN_CENTROID_R_STEPS + j;
    vec2 near_r = mix(sheen_centroid_entry(k), sheen_centroid_entry(k + SHEEN_CENTROID_R_STEPS), x - float(i));
    vec2 far_r = mix(sheen_centroid_entry(k + 1), sheen_centroid_entry(k + 1 + SHEEN_CENTROID_R_STEPS), x - float(i));
    return mix(near_r, far_r, y - float(j));
}
#endif

// The base's diffuse scaling under light from every direction: the cosine-weighted mean over
// N.L of min(1 - c E_s(N.V), 1 - c E_s(N.L)), by 8-point Gauss-Legendre in u = N.L^2 (where the
// cosine weight is uniform; within 0.005 of a 4000-point rule).
const float SHEEN_U_NODES[8] = float[8](0.01985507, 0.10166676, 0.23723380, 0.40828268,
                                        0.59171732, 0.76276620, 0.89833324, 0.98014493);
const float SHEEN_U_WEIGHTS[8] = float[8](0.05061427, 0.11119052, 0.15685332, 0.18134189,
                                          0.18134189, 0.15685332, 0.11119052, 0.05061427);

float sheen_diffuse_scaling(float c, float e_sheen_view, float sheen_perceptual_roughness) {
    float sum = 0.0;
    for (int i = 0; i < 8; i++) {
        float e_l = sheen_albedo(sqrt(SHEEN_U_NODES[i]), sheen_perceptual_roughness);
        sum += SHEEN_U_WEIGHTS[i] * min(1.0 - c * e_sheen_view, 1.0 - c * e_l);
    }
    return sum;
}

#if IBL_METHOD == sampled
#include "hammersley.glsl"
#include "sampling.glsl"

// The sampled path's (the high preset's) specular scaling under light from every direction:
// 1 - c max(E_s(N.V), E_s(N.L)) (the min above) averaged over the base's GGX lobe, weighted per
// channel as its light is: f cos with F = f0_a (1 - Fc) + f0_b Fc (f0_a, f0_b: what multiplies
// the DFG's A and B, the dielectric and metal lobes mixed by metallic). By an 8 x 4
// Gauss-Legendre product over the visible-normal square (Heitz 2018; only N.V matters, so V
// lies in the x-z plane), the azimuth over the half on one side of the N-V plane (the lobe is
// mirror-symmetric about it); u's nodes are the rule's above. Within 0.009 of the float64
// ratio for the lobes scene's material, 0.017 for a white sheen (tests/test_lobes.py bounds
// it per pixel); the simplified form is up to 0.08 off.
const float SHEEN_AZIMUTH_NODES[4] = float[4](-0.21528408, -0.08499526, 0.08499526, 0.21528408);
const float SHEEN_AZIMUTH_WEIGHTS[4] = float[4](0.17392742, 0.32607258, 0.32607258, 0.17392742);

vec3 sheen_specular_scaling(Material m, float c, float e_sheen_view, float n_dot_v) {
#if KHR_SPECULAR
    float weight = m.specular_weight;
#else
    float weight = 1.0;
#endif
    vec3 f0_a = mix(weight * dielectric_f0(m), m.base_color_linear, m.metallic);
    float f0_b = mix(weight, 1.0, m.metallic);
    vec3 v_local = vec3(sqrt(max(1.0 - n_dot_v * n_dot_v, 0.0)), 0.0, n_dot_v);
    vec3 lobe = vec3(0.0), scaled = vec3(0.0);
    for (int i = 0; i < 8; i++) {
        for (int j = 0; j < 4; j++) {
            // l = reflect(-v, h); its f cos / pdf is Vis N.L times a constant of the pixel.
            vec3 h = sample_ggx_vndf(v_local, m.alpha, vec2(SHEEN_U_NODES[i], SHEEN_AZIMUTH_NODES[j]));
            float v_dot_h = dot(v_local, h);
            float n_dot_l = 2.0 * v_dot_h * h.z - n_dot_v;
            if (n_dot_l <= 0.0) continue;
            float fc = pow5_one_minus(v_dot_h);
            vec3 w = (SHEEN_U_WEIGHTS[i] * SHEEN_AZIMUTH_WEIGHTS[j] * visibility_ibl(n_dot_l, n_dot_v, m.alpha) * n_dot_l)
                   * (f0_a * (1.0 - fc) + f0_b * fc);
            lobe += w;
            scaled += w * max(e_sheen_view, sheen_albedo(n_dot_l, m.sheen_perceptual_roughness));
        }
    }
    return 1.0 - c * scaled / max(lobe, vec3(1e-20));
}

// The sampled path's sheen (the high preset): the mean radiance its lobe gathers, integrated per
// pixel like the specular (ibl_sampled.glsl): SHEEN_PIXEL_SAMPLES cosine-weighted directions
// (the Charlie lobe is wide), each weighted by f_sheen / (cos / pi) and read from the
// prefiltered map at the level whose kernel covers its solid angle, through the stage's
// parallax. A ratio estimator: under a uniform environment it is that radiance, exactly.
// The SH9 read along the lobe's mean direction (below) put the sheen 2 % bright at N.V 0.35-0.6
// and 1.3 % dark at N.V > 0.85 under the studio (lobes scene, environment only).
#define SHEEN_PIXEL_SAMPLES (IBL_PIXEL_SAMPLES / 2)
vec3 sampled_sheen_radiance(Material m, vec3 n, vec3 v, float n_dot_v) {
    vec3 t, b;
    basis(n, t, b);
    float alpha = sq(m.sheen_perceptual_roughness);
    uint count = uint(SHEEN_PIXEL_SAMPLES);
    vec3 sum = vec3(0.0);
    float weights = 0.0;
    for (uint i = 0u; i < count; ++i) {
        vec3 l_local = sample_cosine_hemisphere(hammersley(i, count));
        if (l_local.z <= 0.0) continue;
        vec3 l = l_local.x * t + l_local.y * b + l_local.z * n;
        float w = d_charlie(saturate(dot(n, normalize(v + l))), alpha) * v_sheen(l_local.z, n_dot_v, alpha);
        sum += w * sampled_radiance(l, filtered_lod(PI / (float(count) * l_local.z)));
        weights += w;
    }
    return sum / max(weights, 1e-20);
}
#endif

// The irradiance the sheen lobe gathers, in the cosine lobe's units (E / pi is its mean radiance).
vec3 sheen_irradiance(Material m, vec3 n, vec3 v, float n_dot_v) {
#if SHEEN_LEAN
    vec3 t = v - n_dot_v * n;
    float t_length = length(t);
    vec2 c = sheen_centroid(n_dot_v, m.sheen_perceptual_roughness);
    vec3 axis = c.x * n + (t_length > 1e-6 ? c.y / t_length : 0.0) * t;
    float band1 = 1.5 * length(axis);
    vec3 d = axis / max(length(axis), 1e-6);
#else
    vec3 d = n;
    float band1 = 1.0;
#endif
    vec3 irradiance = sh_irradiance_banded(d, band1, band1 * band1);
#if FLOOR_PARALLAX
    irradiance += floor_parallax_irradiance(d);
#endif
    return irradiance;
}
#endif

// bounce_ray (a literal): the cells stage's bounce rays, which average the sphere's light over
// its cap onto the floor, take the split sum's sheen on the sampled path too (its per-pixel
// integrals there cost 5 rays x 160 lookups a floor pixel for light the average smooths out).
vec3 layer_ibl(Material m, vec3 n, vec3 v, float n_dot_v, vec3 base, vec3 base_diffuse, bool bounce_ray) {
    vec3 color = base;
#if SHEEN
    float e_sheen = sheen_albedo(n_dot_v, m.sheen_perceptual_roughness);
#if !BUG_SHEEN_NO_SCALING
    float c = max3(m.sheen_color_linear);
    vec3 specular_scaling = vec3(1.0 - c * e_sheen);
#if IBL_METHOD == sampled
    if (!bounce_ray) specular_scaling = sheen_specular_scaling(m, c, e_sheen, n_dot_v);
#endif
    color = (base - base_diffuse) * specular_scaling
          + base_diffuse * sheen_diffuse_scaling(c, e_sheen, m.sheen_perceptual_roughness);
#endif
#if IBL_METHOD == sampled
    if (!bounce_ray) color += m.sheen_color_linear * e_sheen * sampled_sheen_radiance(m, n, v, n_dot_v);
    else
#endif
    color += m.sheen_color_linear * e_sheen * sheen_irradiance(m, n, v, n_dot_v) * INV_PI;
#endif
#if CLEARCOAT
    vec3 n_c = m.clearcoat_normal;
    float n_c_dot_v = max(dot(n_c, v), MIN_N_DOT_V);
    vec3 dfg_c = dfg_lookup(n_c_dot_v, m.clearcoat_perceptual_roughness);
    vec3 coat = prefiltered_radiance(reflect(-v, n_c), m.clearcoat_perceptual_roughness) * (dfg_c.x + dfg_c.y);
#if BOUNCE_MIRROR_DIRECTIONS > 0
    // The bounce rays: the coat's image of the sky is stage_bounce.glsl's closed form but for
    // the share the rays resolve; they keep its image of the floor (as the base's, shade.glsl).
    if (bounce_ray && !floor_lobe_reads())
        coat *= mix(1.0, bounce_resolves(m.clearcoat_alpha), mirrored_sky_share(reflect(-v, n_c).y));
#endif
#if BUG_CLEARCOAT_ADDS
    color += coat * clearcoat_weight(m, v);
#else
    color = mix(color, coat, clearcoat_weight(m, v));
#endif
#endif
    return color;
}
