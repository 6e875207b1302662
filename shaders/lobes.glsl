// The KHR layers over the core material (docs/lobes.md has the equations and the choices):
// KHR_materials_sheen as its spec and glTF-Sample-Viewer write it (Charlie distribution,
// Charlie visibility with its fitted lambda, albedo scaling by the sheen's directional albedo
// E_s from the DFG LUT's alpha channel), KHR_materials_clearcoat as its spec writes it
// (fresnel_coat: mix(base, D V of the coat, clearcoat F(N_c.V)), f0 = 0.04).

#if SHEEN
#include "sheen.glsl"

// The sheen's directional albedo E_s(NdotV, sheen roughness) (sheen colour 1).
float sheen_albedo(float n_dot_v, float sheen_perceptual_roughness) {
    return dfg_sheen_lookup(n_dot_v, sheen_perceptual_roughness);
}

// f = f_sheen + f_base * min(1 - max3(c) E_s(N.V), 1 - max3(c) E_s(N.L)) (the spec's albedo
// scaling, its exact form for lights).
vec3 sheen_layer(Material m, vec3 f_base, vec3 n, vec3 v, vec3 l, float n_dot_v, float n_dot_l) {
    float alpha = sq(m.sheen_perceptual_roughness);
    float n_dot_h = saturate(dot(n, normalize(v + l)));
    vec3 f_sheen = m.sheen_color_linear * d_charlie(n_dot_h, alpha) * v_sheen(n_dot_l, n_dot_v, alpha);
#if BUG_SHEEN_NO_SCALING
    return f_sheen + f_base;
#endif
    float strength = max3(m.sheen_color_linear);
    float scaling = min(1.0 - strength * sheen_albedo(n_dot_v, m.sheen_perceptual_roughness),
                        1.0 - strength * sheen_albedo(n_dot_l, m.sheen_perceptual_roughness));
    return f_sheen + f_base * scaling;
}
#endif

#if CLEARCOAT
void set_clearcoat_roughness(inout Material m, float perceptual_roughness) {
    m.clearcoat_perceptual_roughness = max(perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS);
    m.clearcoat_alpha = alpha_from_perceptual(m.clearcoat_perceptual_roughness);
}

// The coat's weight towards the viewer: clearcoat * F(N_c.V), f0 = 0.04 (ior 1.5), f90 = 1.
float clearcoat_weight(Material m, vec3 v) {
    float x = max(dot(m.clearcoat_normal, v), MIN_N_DOT_V);
    return m.clearcoat * (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * pow5_one_minus(x));
}

// mix(base f cos, coat D V cos, weight): base_cos is the base's f cos.
vec3 clearcoat_layer(Material m, vec3 base_cos, vec3 v, vec3 l, float light_angle) {
    vec3 n = m.clearcoat_normal;
    float n_dot_l = dot(n, l);
    float n_dot_v = max(dot(n, v), MIN_N_DOT_V);
    float coat = 0.0;
    if (n_dot_l > 0.0) {
        // A disc light as in base_brdf_cos (brdf.glsl d_ggx_light).
        coat = d_ggx_light(n, v, l, m.clearcoat_alpha, light_angle)
             * visibility_direct(n_dot_l, n_dot_v, m.clearcoat_perceptual_roughness, m.clearcoat_alpha) * n_dot_l;
    }
#if BUG_CLEARCOAT_ADDS
    return base_cos + coat * clearcoat_weight(m, v);
#else
    return mix(base_cos, vec3(coat), clearcoat_weight(m, v));
#endif
}
#endif
