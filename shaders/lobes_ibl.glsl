// The KHR layers of lobes.glsl under the environment, over the base's IBL:
// sheen: colour x E_s(N.V) x the mean radiance its lobe gathers; the base's specular scaled by
// 1 - max3(colour) E_s(N.V) (its light comes in about the mirror direction, where N.L = N.V),
// its diffuse by the spec's exact min(1 - c E_s(N.V), 1 - c E_s(N.L)) averaged over the cosine
// (the simplified form on both, the base's diffuse at N.V > 0.5 read 2-7 % brighter than
// the reference's exact form under the furnace). The lobe is wide and leans from N
// towards V and the horizon: with SHEEN_LEAN the irradiance is read along the lobe's mean
// direction c (shading.sheen's float64 table), its first band scaled by |c| over the cosine's
// 2/3 (exact for bands 0 and 1) and its second by the square; else along N, as a cosine lobe;
// clearcoat: the coat's split sum E_c(N_c.V) x the prefiltered radiance along the coat's
// mirror direction at its roughness, mixed over the rest by clearcoat F(N_c.V).
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

vec3 layer_ibl(Material m, vec3 n, vec3 v, float n_dot_v, vec3 base, vec3 base_diffuse) {
    vec3 color = base;
#if SHEEN
    float e_sheen = sheen_albedo(n_dot_v, m.sheen_perceptual_roughness);
#if !BUG_SHEEN_NO_SCALING
    float c = max3(m.sheen_color_linear);
    color = (base - base_diffuse) * (1.0 - c * e_sheen)
          + base_diffuse * sheen_diffuse_scaling(c, e_sheen, m.sheen_perceptual_roughness);
#endif
    color += m.sheen_color_linear * e_sheen * sheen_irradiance(m, n, v, n_dot_v) * INV_PI;
#endif
#if CLEARCOAT
    vec3 n_c = m.clearcoat_normal;
    float n_c_dot_v = max(dot(n_c, v), MIN_N_DOT_V);
    vec3 dfg_c = dfg_lookup(n_c_dot_v, m.clearcoat_perceptual_roughness);
    vec3 coat = prefiltered_radiance(reflect(-v, n_c), m.clearcoat_perceptual_roughness) * (dfg_c.x + dfg_c.y);
#if BUG_CLEARCOAT_ADDS
    color += coat * clearcoat_weight(m, v);
#else
    color = mix(color, coat, clearcoat_weight(m, v));
#endif
#endif
    return color;
}
