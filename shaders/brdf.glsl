// The glTF 2.0 Appendix-B metallic-roughness material (docs/model.md, the BRDF) and, composed in only
// where a chart uses them, the KHR lobes of lobes.glsl (docs/lobes.md): KHR_SPECULAR
// (KHR_materials_specular and _ior), CLEARCOAT, SHEEN, EMISSION.

struct Material {
    vec3 base_color_linear;
    float metallic;
    float perceptual_roughness;   // clamped to MIN_PERCEPTUAL_ROUGHNESS
    float alpha;                  // perceptual_roughness^2
#if KHR_SPECULAR
    vec3 specular_f0;             // min(((ior - 1) / (ior + 1))^2 specular_color, 1)
    float specular_weight;        // KHR_materials_specular's specular factor
#endif
#if CLEARCOAT
    float clearcoat;
    float clearcoat_perceptual_roughness;   // clamped as perceptual_roughness
    float clearcoat_alpha;
    vec3 clearcoat_normal;        // the geometric normal (no clearcoat normal map)
#endif
#if SHEEN
    vec3 sheen_color_linear;
    float sheen_perceptual_roughness;       // clamped as perceptual_roughness
#endif
#if EMISSION
    vec3 emission_linear;         // emissive colour times emissive strength
#endif
};

float alpha_from_perceptual(float r) {
#if BUG_UNSQUARED_ROUGHNESS
    return r;
#else
    return r * r;
#endif
}

void set_roughness(inout Material m, float perceptual_roughness) {
    m.perceptual_roughness = max(perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS);
    m.alpha = alpha_from_perceptual(m.perceptual_roughness);
}

// A core material; every composed lobe starts switched off (ior 1.5, specular 1).
Material make_material(vec3 base_color_linear, float metallic, float perceptual_roughness) {
    Material m;
    m.base_color_linear = base_color_linear;
    m.metallic = metallic;
    set_roughness(m, perceptual_roughness);
#if KHR_SPECULAR
    m.specular_f0 = vec3(DIELECTRIC_F0);
    m.specular_weight = 1.0;
#endif
#if CLEARCOAT
    m.clearcoat = 0.0;
    m.clearcoat_perceptual_roughness = MIN_PERCEPTUAL_ROUGHNESS;
    m.clearcoat_alpha = sq(MIN_PERCEPTUAL_ROUGHNESS);
    m.clearcoat_normal = vec3(0.0, 1.0, 0.0);
#endif
#if SHEEN
    m.sheen_color_linear = vec3(0.0);
    m.sheen_perceptual_roughness = MIN_PERCEPTUAL_ROUGHNESS;
#endif
#if EMISSION
    m.emission_linear = vec3(0.0);
#endif
    return m;
}

// A disc light of angular radius theta around l: its half vectors fill a disc of radius
// w = sin(theta) / (2 sqrt(V.H)) in slope space (its solid angle over the reflection's Jacobian
// 4 V.H, V.H at the disc's centre), which D sees convolved (ggx.glsl d_ggx_disc); the other
// factors are taken at the centre. Against float64 integration over the disc (400 points), a
// white metal sphere's light per band of angle from the highlight is within 2 % from r = 0.18
// to 1 at 6 and 10 degrees (tests/test_lights.py). Karis 2013's representative point, with D
// renormalised to keep the disc's energy, held the total within 3 % but not its place: the
// core up to 1.5x, the tails 0.2-0.6x (10 degrees, r = 0.18-0.25).
float disc_half_radius(float angular_radius, vec3 v, vec3 l) {
    return sin(angular_radius) / (2.0 * sqrt(max(abs(dot(v, normalize(v + l))), 1e-4)));
}

// D for a light of angular radius light_angle (0: a point-like light) around l.
float d_ggx_light(vec3 n, vec3 v, vec3 l, float alpha, float light_angle) {
    vec3 h = normalize(v + l);
    return light_angle > 0.0 ? d_ggx_disc(n, h, alpha, disc_half_radius(light_angle, v, l)) : d_ggx(n, h, alpha);
}

// The dielectric Fresnel at cos x: Schlick with f0 = 0.04, or KHR_materials_specular's
// weight (f0 + (1 - f0) (1 - x)^5) with the material's f0 (fresnel_mix of the extension).
vec3 dielectric_fresnel(Material m, float x) {
#if KHR_SPECULAR
    return m.specular_weight * (m.specular_f0 + (1.0 - m.specular_f0) * pow5_one_minus(x));
#else
    return vec3(DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * pow5_one_minus(x));
#endif
}

// The Fresnel of m's specular layer at cos x: its metal and dielectric lobes mixed by
// metallic, as brdf_cos mixes them (a sphere's reflection of the lights in closed form).
vec3 sphere_fresnel(Material m, float x) {
    return mix(dielectric_fresnel(m, x), fresnel_schlick(m.base_color_linear, x), m.metallic);
}

vec3 dielectric_f0(Material m) {
#if KHR_SPECULAR
    return m.specular_f0;
#else
    return vec3(DIELECTRIC_F0);
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

#if SHEEN || CLEARCOAT
#include "lobes.glsl"
#endif

#if EMISSION
// Emission seen from v: under a clearcoat, less the share the coat reflects (the spec's
// coated_emission).
vec3 surface_emission(Material m, vec3 v) {
#if CLEARCOAT
    return m.emission_linear * (1.0 - clearcoat_weight(m, v));
#else
    return m.emission_linear;
#endif
}
#endif

// The body's Lambert lobe, weighted by the share of light the coat lets in: 1 - F at cos x.
vec3 diffuse_lobe(Material m, float f_cos) {
#if BUG_DIFFUSE_NO_FRESNEL
    return m.base_color_linear * INV_PI;
#else
    return m.base_color_linear * INV_PI * (1.0 - max3(dielectric_fresnel(m, f_cos)));
#endif
}

// The base under the clearcoat: the core material, under SHEEN with the sheen layer over it.
vec3 base_brdf_cos(Material m, vec3 n, vec3 v, vec3 l, float n_dot_v, float light_angle, float e_single) {
    float n_dot_l = dot(n, l);
    float alpha_light = m.alpha;
    vec3 h = normalize(v + l);
    float v_dot_h = abs(dot(v, h));
    float n_dot_ls = max(n_dot_l, 1e-6);
    float d = d_ggx_light(n, v, l, alpha_light, light_angle);
#if BUG_UNCLAMPED_NDOTV
    // The textbook D G F / (4 N.L N.V) with G symmetric in N.V (Smith's Lambda reads tan^2) and
    // N.V unclamped: equal to the visibility form wherever N.V > 0, and negative where a normal
    // map tilts the shading normal away from the camera (black specks; 0/0 at N.V = 0).
    float f_spec = d * sign(n_dot_v) * visibility_direct(n_dot_ls, abs(n_dot_v), m.perceptual_roughness, alpha_light);
#else
    float f_spec = d * visibility_direct(n_dot_ls, n_dot_v, m.perceptual_roughness, alpha_light);
#endif
#if BUG_FRESNEL_NDOTV
    float f_cos = n_dot_v;
    float f_cos_diffuse = n_dot_v;
#else
    float f_cos = v_dot_h;
    float f_cos_diffuse = v_dot_h;
#endif
    vec3 f_dielectric = dielectric_fresnel(m, f_cos);
    vec3 diffuse = diffuse_lobe(m, f_cos_diffuse);
    vec3 spec_dielectric = f_spec * f_dielectric * energy_compensation(dielectric_f0(m), e_single);
    vec3 metal = f_spec * fresnel_schlick(m.base_color_linear, f_cos)
               * energy_compensation(m.base_color_linear, e_single);
#if BUG_METAL_DIFFUSE
    vec3 f = diffuse + mix(spec_dielectric, metal, m.metallic);
#else
    vec3 f = mix(diffuse + spec_dielectric, metal, m.metallic);
#endif
#if SHEEN
    f = sheen_layer(m, f, n, v, l, n_dot_v, n_dot_l);
#endif
#if BUG_NO_COSINE
    return f;
#elif BUG_COSINE_TWICE
    return f * n_dot_l * n_dot_l;
#else
    return f * n_dot_l;
#endif
}

// The diffuse share of f(v, l) * NdotL alone (no layers): a sphere's light on its floor besides
// its mirror-like reflection of the lights, which sphere_mirror.glsl takes in closed form.
vec3 diffuse_brdf_cos(Material m, vec3 n, vec3 v, vec3 l) {
    float n_dot_l = dot(n, l);
    if (n_dot_l <= 0.0) return vec3(0.0);
#if BUG_METAL_DIFFUSE
    float body = 1.0;
#else
    float body = 1.0 - m.metallic;
#endif
    return body * diffuse_lobe(m, abs(dot(v, normalize(v + l)))) * n_dot_l;
}

// f(v, l) * NdotL for one light direction; e_single from the DFG LUT at (NdotV, r).
// light_angle: the light's angular radius (a disc; d_ggx_light).
vec3 brdf_cos(Material m, vec3 n, vec3 v, vec3 l, float n_dot_v, float light_angle, float e_single) {
    float n_dot_l = dot(n, l);
#if CLEARCOAT
    if (n_dot_l <= 0.0 && dot(m.clearcoat_normal, l) <= 0.0) return vec3(0.0);
    vec3 base = n_dot_l <= 0.0 ? vec3(0.0) : base_brdf_cos(m, n, v, l, n_dot_v, light_angle, e_single);
    return clearcoat_layer(m, base, v, l, light_angle);
#else
    if (n_dot_l <= 0.0) return vec3(0.0);
    return base_brdf_cos(m, n, v, l, n_dot_v, light_angle, e_single);
#endif
}
