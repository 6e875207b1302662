// The glTF 2.0 Appendix-B metallic-roughness material (REFERENCE.md §1).

struct Material {
    vec3 base_color_linear;
    float metallic;
    float perceptual_roughness;   // clamped to MIN_PERCEPTUAL_ROUGHNESS
    float alpha;                  // perceptual_roughness^2
};

Material make_material(vec3 base_color_linear, float metallic, float perceptual_roughness) {
    float r = max(perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS);
#if BUG_UNSQUARED_ROUGHNESS
    return Material(base_color_linear, metallic, r, r);
#else
    return Material(base_color_linear, metallic, r, r * r);
#endif
}

// Multiple-scattering compensation (Filament's Kulla-Conty simplification): scale a specular
// lobe of reflectance f0 by 1 + f0 (1/E - 1), E the single-scatter albedo for F = 1.
// Each lobe of the glTF mix is compensated with its own f0 before the metallic mix.
vec3 energy_compensation(vec3 f0, float e_single) {
#if MULTISCATTER
    return 1.0 + f0 * (1.0 / max(e_single, 1e-4) - 1.0);
#else
    return vec3(1.0);
#endif
}

// f(v, l) * NdotL for one light direction; e_single from the DFG LUT at (NdotV, r).
// alpha_light is the material alpha widened for the light's angular size.
vec3 brdf_cos(Material m, vec3 n, vec3 v, vec3 l, float n_dot_v, float alpha_light, float e_single) {
    float n_dot_l = dot(n, l);
    if (n_dot_l <= 0.0) return vec3(0.0);
    vec3 h = normalize(v + l);
    float n_dot_h = saturate(dot(n, h));
    float v_dot_h = abs(dot(v, h));
#if BUG_UNCLAMPED_NDOTV
    // The textbook D G F / (4 N.V N.L), separable Smith, N.V unclamped: at rims where the
    // shading normal faces away it divides by zero or goes negative.
    float a2 = alpha_light * alpha_light;
    float g_v = 2.0 * n_dot_v / (n_dot_v + sqrt(a2 + (1.0 - a2) * n_dot_v * n_dot_v));
    float g_l = 2.0 * n_dot_l / (n_dot_l + sqrt(a2 + (1.0 - a2) * n_dot_l * n_dot_l));
    float f_spec = d_ggx(n_dot_h, alpha_light) * g_v * g_l / (4.0 * n_dot_v * n_dot_l);
#else
    float f_spec = d_ggx(n, h, alpha_light) * visibility_direct(n_dot_l, n_dot_v, m.perceptual_roughness, alpha_light);
#endif
#if BUG_FRESNEL_NDOTV
    float f_cos = n_dot_v;
#else
    float f_cos = v_dot_h;
#endif
    float f_dielectric = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * pow5_one_minus(f_cos);
#if BUG_DIFFUSE_NO_FRESNEL
    vec3 diffuse = m.base_color_linear * INV_PI;
#else
    vec3 diffuse = m.base_color_linear * INV_PI * (1.0 - f_dielectric);
#endif
    vec3 spec_dielectric = f_spec * f_dielectric * energy_compensation(vec3(DIELECTRIC_F0), e_single);
    vec3 metal = f_spec * fresnel_schlick(m.base_color_linear, f_cos)
               * energy_compensation(m.base_color_linear, e_single);
#if BUG_METAL_DIFFUSE
    vec3 f = diffuse + mix(spec_dielectric, metal, m.metallic);
#else
    vec3 f = mix(diffuse + spec_dielectric, metal, m.metallic);
#endif
#if BUG_NO_COSINE
    return f;
#elif BUG_COSINE_TWICE
    return f * n_dot_l * n_dot_l;
#else
    return f * n_dot_l;
#endif
}
