// A sphere's specular reflection of the punctual lights onto a floor (normal +y) as a mirror
// ball's: the cells stage's floor under its sphere, the shared stage's under its spheres. A
// parallel beam (illuminance E, from direction l) reflects off the point s = R n whose normal
// n is halfway between l and the direction from s to the floor point q (found by fixed-point
// steps from the far field's). A convex mirror's reflected beam diverges from two focal lines
// (astigmatic: R cos(i) / 2 and R / (2 cos(i)) behind s, i the incidence), so at distance D
// from s it carries E F f_t f_s / ((D + f_t)(D + f_s)) = E F R^2 / (4 (D + f_t)(D + f_s))
// across the ray. The far field's even spread, E R^2 F / (4 d^2) at distance d from the centre,
// is its limit. A rough sphere blurs the image without changing it much.
// Near the sphere the far field misplaces the light. Behind the sphere (its shadow) the
// mirror point is on the side q cannot see: under the key light alone, the cells stage's
// shadow core read 1.3-1.9x the reference with the far field. Beside the sphere a beam not
// yet spread is brighter. The image is seen in the share of it (widened by `spread`: the
// light's angular radius and the lobe's) above s's tangent plane as q sees it.
// Fixed-point steps to the mirror point from the far field's: one (three moved no measured
// figure: the tests' regions by 0.1 %, the cells and shared charts by 0.0001 mean FLIP; on the
// shared stage, where every floor pixel takes 9 spheres' images, they cost 8 % more draw).
#define MIRROR_POINT_STEPS 1

// The Fresnel of a sphere's mirror image at cos x: its specular layer's, less what the layers
// over it take first (at the mirror point N.V = N.L = x): a sheen's albedo scaling,
// 1 - max3(c) E_s(x), and a coat's reflection, clearcoat F_c(x) (KHR_materials_sheen and
// _clearcoat). Left out, the lobes scene's floor in front of its smooth spheres read up to
// 1.1 % bright at `high`.
vec3 mirror_fresnel(Material m, float x) {
    vec3 f = sphere_fresnel(m, x);
#if SHEEN && !BUG_SHEEN_NO_SCALING
    f *= 1.0 - max3(m.sheen_color_linear) * sheen_albedo(x, m.sheen_perceptual_roughness);
#endif
#if CLEARCOAT && !BUG_CLEARCOAT_ADDS
    f *= 1.0 - m.clearcoat * fresnel_schlick(vec3(DIELECTRIC_F0), x).x;
#endif
    return f;
}

// The light's irradiance at q (from the sphere's centre) per unit illuminance and Fresnel;
// cos_i: the incidence at s.
float mirror_irradiance(vec3 q, vec3 l, float spread, out float cos_i) {
    cos_i = 0.0;
    vec3 h = l + normalize(q);
    for (int k = 0; k < MIRROR_POINT_STEPS; ++k) {
        float len = length(h);
        if (len <= 1e-4) return 0.0;   // q straight behind the sphere
        h = l + normalize(q - u_radius * h / len);
    }
    float len = length(h);
    if (len <= 1e-4) return 0.0;
    vec3 n = h / len;
    vec3 to_q = q - u_radius * n;
    float dist = length(to_q);
    vec3 dir = to_q / dist;
    float cos_q = -dir.y;   // the floor's normal is +y
    if (cos_q <= 0.0) return 0.0;
    cos_i = saturate(dot(n, l));
    float seen = saturate(0.5 + 0.5 * dot(n, dir) / max(sin(spread), 1e-3));
    float f_t = 0.5 * u_radius * cos_i, f_s = 0.5 * u_radius / max(cos_i, 1e-4);
    return 0.25 * sq(u_radius) / ((dist + f_t) * (dist + f_s)) * cos_q * seen;
}

// The irradiance at floor point p from the sphere (centre c, material m) mirroring every light.
vec3 sphere_reflected_light(vec3 p, vec3 c, Material m) {
    vec3 q = p - c;
    vec3 sum = vec3(0.0);
    float cos_i;
#if NUM_DIR_LIGHTS > 0
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i) {
        float e = mirror_irradiance(q, u_dir_light_direction[i], u_dir_light_angular_radius[i] + m.alpha, cos_i);
        sum += mirror_fresnel(m, cos_i) * u_dir_light_illuminance[i] * e;
    }
#endif
#if NUM_POINT_LIGHTS > 0
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {
        vec3 to_light = u_point_light_position[i] - c;   // as a distant light from the centre
        float d_light = length(to_light);
        vec3 l = to_light / max(d_light, 1e-6);
        float e = mirror_irradiance(q, l, m.alpha, cos_i);
        sum += mirror_fresnel(m, cos_i) * u_point_light_intensity[i] * point_falloff(d_light, u_point_light_range[i]) * e;
    }
#endif
    return sum;
}
