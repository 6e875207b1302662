// The KHR layers of lobes.glsl under the environment, over the base's IBL:
// sheen: colour x E_s(N.V) x the cosine-weighted mean radiance E(n)/pi (the Charlie lobe is
// wide and leans to the horizon; no prefiltered map of its own), the base scaled by
// 1 - max3(colour) E_s(N.V) (the spec's simplified scaling);
// clearcoat: the coat's split sum E_c(N_c.V) x the prefiltered radiance along the coat's
// mirror direction at its roughness, mixed over the rest by clearcoat F(N_c.V).
vec3 layer_ibl(Material m, vec3 n, vec3 v, float n_dot_v, vec3 base) {
    vec3 color = base;
#if SHEEN
    float e_sheen = sheen_albedo(n_dot_v, m.sheen_perceptual_roughness);
#if !BUG_SHEEN_NO_SCALING
    color *= 1.0 - max3(m.sheen_color_linear) * e_sheen;
#endif
    vec3 irradiance = sh_irradiance(n);
#if FLOOR_PARALLAX
    irradiance += floor_parallax_irradiance(n);
#endif
    color += m.sheen_color_linear * e_sheen * irradiance * INV_PI;
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
