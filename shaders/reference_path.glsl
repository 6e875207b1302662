// The reference path tracer's integrator: the chart's scene, materials (brdf.glsl, each
// surface's E from an exact table), environment (env.glsl evaluated per ray) and lights, with
// next-event estimation for every light and the environment, and multiple importance sampling
// (power heuristic) between BRDF sampling and each light or environment sampling technique.
// Directional lights of angular radius theta > 0 are discs of radiance E / (pi sin^2 theta)
// (what the chart shows in its background); point lights of radius R > 0 are spheres of
// radiance I w(d) / (pi R^2) (E = I w(d) / d^2 on a surface that sees all of it; w the range
// window at the centre's distance d), seen by the paths' bounces but not by camera rays, as in
// the chart, and hiding nothing; theta = 0 and R = 0 lights are delta lights.
// Textured spheres: the maps modulate the cell's factors and bend the shading normal as in
// shade.glsl, read at full resolution (pixel samples do the filtering); light below the
// geometric surface is blocked by it; the ORM occlusion darkens indirect light only (the
// environment and interreflections), as in the chart.
uniform int u_max_bounces;   // surface interactions per path; 1 = direct light only
uniform int u_lambert_only;  // validation: every surface a Lambert reflector of its base colour

struct Surface {
    Material m;
    vec3 n;             // shading normal
    vec3 n_geometric;
    float occlusion;    // ORM occlusion (1 without textures)
    float n_dot_v;      // clamped as the chart clamps it
    float e_single;     // single-scatter specular albedo for the energy compensation
    float p_specular;   // probability of sampling the GGX lobe instead of the cosine lobe
    float p_coat;       // CLEARCOAT: probability of sampling the coat's GGX lobe
};

Surface make_surface(ivec2 cell, vec3 n_geometric, vec3 v) {
    Material m = cell.x < 0 ? ground_material() : cell_material(cell, n_geometric);
    vec3 n = n_geometric;
    float occlusion = 1.0;
#if USE_TEXTURES
    if (cell.x >= 0) {
        SurfaceTexels tx = sample_surface(n_geometric, 1e-20 * u_radius, cell);   // level 0
        apply_texels(m, cell, tx);
        occlusion = tx.orm.r;
        n = tx.normal;
    }
#endif
    float n_dot_v = max(dot(n, v), MIN_N_DOT_V);
    vec3 dfg = dfg_lookup(n_dot_v, m.perceptual_roughness);
    // Lobe selection by the lobes' reflectance at this view angle; the mixture pdf below is
    // exact whatever the split, so this only steers variance.
    float f_dielectric = max3(dielectric_fresnel(m, n_dot_v));
    float specular = mix(f_dielectric, luminance(fresnel_schlick(m.base_color_linear, n_dot_v)), m.metallic);
    float diffuse = (1.0 - m.metallic) * luminance(m.base_color_linear) * (1.0 - f_dielectric);
#if SHEEN
    diffuse += max3(m.sheen_color_linear);   // the wide sheen lobe is sampled by the cosine lobe
#endif
    float p_specular = diffuse > 0.0 ? clamp(specular / (specular + diffuse), 0.1, 0.9) : 1.0;
    float p_coat = 0.0;
#if CLEARCOAT
    // The coat by its weight towards the viewer, never below 0.1 where it is on.
    p_coat = m.clearcoat > 0.0 ? clamp(clearcoat_weight(m, v) * 4.0, 0.1, 0.5) : 0.0;
    p_specular *= 1.0 - p_coat;
#endif
    if (u_lambert_only != 0) p_specular = p_coat = 0.0;
    return Surface(m, n, n_geometric, occlusion, n_dot_v, dfg.x + dfg.y, p_specular, p_coat);
}

// f(v, l) cos(theta_l): the chart's brdf_cos, with the material's own alpha (no widening).
vec3 surface_f_cos(Surface s, vec3 v, vec3 l) {
#if USE_TEXTURES
    if (dot(s.n_geometric, l) <= 0.0) return vec3(0.0);   // below the true surface
#endif
    if (u_lambert_only != 0) return s.m.base_color_linear * INV_PI * max(dot(s.n, l), 0.0);
    return brdf_cos(s.m, s.n, v, l, s.n_dot_v, 0.0, s.e_single);
}

// The mixture of the coat's GGX lobe (p_coat), the base's (p_specular) and the cosine lobe.
float surface_pdf(Surface s, vec3 v, vec3 l) {
    float pdf = 0.0;
#if CLEARCOAT
    if (s.p_coat > 0.0 && dot(s.m.clearcoat_normal, l) > 0.0)
        pdf += s.p_coat * pdf_ggx_vndf_reflection(max(dot(s.m.clearcoat_normal, v), 0.0), s.m.clearcoat_normal,
                                                  normalize(v + l), s.m.clearcoat_alpha);
#endif
    float n_dot_l = dot(s.n, l);
    if (n_dot_l <= 0.0) return pdf;
    pdf += (1.0 - s.p_specular - s.p_coat) * n_dot_l * INV_PI;
    if (s.p_specular > 0.0) {
        vec3 h = normalize(v + l);
        pdf += s.p_specular * pdf_ggx_vndf_reflection(max(dot(s.n, v), 0.0), s.n, h, s.m.alpha);
    }
    return pdf;
}

vec3 surface_sample(Surface s, vec3 v, vec3 u) {
#if CLEARCOAT
    if (u.x < s.p_coat) {
        vec3 n_c = s.m.clearcoat_normal;
        return reflect(-v, to_world(sample_ggx_vndf(to_local(v, n_c), s.m.clearcoat_alpha, u.yz), n_c));
    }
#endif
    if (u.x < s.p_coat + s.p_specular) {
        vec3 h = to_world(sample_ggx_vndf(to_local(v, s.n), s.m.alpha, u.yz), s.n);
        return reflect(-v, h);
    }
    return to_world(sample_cosine_hemisphere(u.yz), s.n);
}

#if NUM_DIR_LIGHTS > 0
float disc_one_minus_cos(int i) { return 2.0 * sq(sin(0.5 * u_dir_light_angular_radius[i])); }
vec3 disc_radiance(int i) { return u_dir_light_illuminance[i] / (PI * sq(sin(u_dir_light_angular_radius[i]))); }
#endif

// Radiance of the lights' discs seen along d, each weighted against BRDF sampling with pdf
// pdf_brdf (pdf_brdf < 0: a camera ray, which no light sampling competes with).
vec3 discs_seen(vec3 d, float pdf_brdf) {
    vec3 sum = vec3(0.0);
#if NUM_DIR_LIGHTS > 0
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i) {
        float theta = u_dir_light_angular_radius[i];
        if (theta > 0.0 && dot(d, u_dir_light_direction[i]) >= cos(theta)) {
            float w = pdf_brdf < 0.0 ? 1.0 : power_heuristic(pdf_brdf, 1.0 / (2.0 * PI * disc_one_minus_cos(i)));
            sum += disc_radiance(i) * w;
        }
    }
#endif
    return sum;
}

#if NUM_POINT_LIGHTS > 0
// A sphere light's radiance, I w(d) / (pi R^2): E = L pi sin^2(asin(R / d)) = I w(d) / d^2.
vec3 sphere_light_radiance(int i, float dist) {
    return u_point_light_intensity[i]
         * (point_falloff(dist, u_point_light_range[i]) * dist * dist / (PI * sq(u_point_light_radius[i])));
}

// 1 - cos of the cone a sphere light subtends from distance dist (> its radius).
float sphere_one_minus_cos(int i, float dist) { return 2.0 * sq(sin(0.5 * point_angular_radius(i, dist))); }

// Radiance of the sphere lights a bounce ray from p along d meets before distance t_max, each
// weighted against BRDF sampling with pdf pdf_brdf (the light's technique: its cone from p).
vec3 spheres_seen(vec3 p, vec3 d, float t_max, float pdf_brdf) {
    vec3 sum = vec3(0.0);
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {
        float radius = u_point_light_radius[i];
        if (radius <= 0.0) continue;
        vec3 to_light = u_point_light_position[i] - p;
        float dist = length(to_light);
        if (dist <= radius) continue;
        float t = ray_sphere(p, d, u_point_light_position[i], radius);
        if (t <= 0.0 || t >= t_max) continue;
        float omc = sphere_one_minus_cos(i, dist);
        float w = power_heuristic(pdf_brdf, 1.0 / (2.0 * PI * omc));
        sum += sphere_light_radiance(i, dist) * w;
    }
    return sum;
}
#endif

vec3 environment_seen(vec3 d, float pdf_brdf) {
#if ENV == black
    return vec3(0.0);
#else
    float w = (pdf_brdf < 0.0 || u_env_sampling == 0) ? 1.0 : power_heuristic(pdf_brdf, environment_pdf(d));
    return env_radiance(d) * w;
#endif
}

#if SEE_THROUGH
// A ray of light meets a sphere as the camera's does: with probability its alpha at the point
// it reaches; else it crosses the sphere (single-sided, a chord of 2 R cos) and goes on, past
// at most MAX_SEE_THROUGH spheres (after that the next one stops it).
#define MAX_SEE_THROUGH 4
Hit trace_light(vec3 ro, vec3 rd, float t_max, ivec2 skip, inout Rng rng) {
    Hit hit = trace_scene(ro, rd, t_max, skip);
    float t_start = 0.0;
    for (int i = 0; i < MAX_SEE_THROUGH && hit.t >= 0.0 && hit.cell.x >= 0; ++i) {
        if (rng_next4(rng).x < sphere_alpha(hit.cell, hit.normal, 1e-20 * u_radius)) break;
        float t_exit = hit.t + 2.0 * u_radius * max(dot(hit.normal, -rd), 0.0);
        t_start += t_exit;
        ro += rd * t_exit;
        Hit behind = trace_scene(ro, rd, t_max - t_start, hit.cell);
        if (behind.t >= 0.0) behind.t += t_start;
        hit = behind;
    }
    return hit;
}
#else
Hit trace_light(vec3 ro, vec3 rd, float t_max, ivec2 skip, inout Rng rng) {
    return trace_scene(ro, rd, t_max, skip);
}
#endif

bool light_blocked(vec3 ro, vec3 rd, float t_max, ivec2 skip, inout Rng rng) {
    return trace_light(ro, rd, t_max, skip, rng).t > 0.0;
}

// Next-event estimation at a surface point: one sample per light and one of the environment,
// each with a shadow ray.
vec3 direct_light(Surface s, vec3 p, vec3 v, ivec2 cell, inout Rng rng) {
    vec3 sum = vec3(0.0);
#if NUM_DIR_LIGHTS > 0
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i) {
        vec3 axis = u_dir_light_direction[i];
        if (u_dir_light_angular_radius[i] > 0.0) {
            float omc = disc_one_minus_cos(i);
            vec3 l = sample_cone(axis, omc, rng_next4(rng).xy);
            vec3 f = surface_f_cos(s, v, l);
            if (any(greaterThan(f, vec3(0.0))) && !light_blocked(p, l, 1e30, cell, rng)) {
                float pdf_light = 1.0 / (2.0 * PI * omc);
                sum += f * disc_radiance(i) * (power_heuristic(pdf_light, surface_pdf(s, v, l)) / pdf_light);
            }
        } else {
            vec3 f = surface_f_cos(s, v, axis);
            if (any(greaterThan(f, vec3(0.0))) && !light_blocked(p, axis, 1e30, cell, rng))
                sum += f * u_dir_light_illuminance[i];
        }
    }
#endif
#if NUM_POINT_LIGHTS > 0
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {
        vec3 to_light = u_point_light_position[i] - p;
        float dist = length(to_light);
        float radius = u_point_light_radius[i];
        if (radius > 0.0) {   // a sphere: its cone from p, MIS against BRDF sampling (spheres_seen)
            if (dist <= radius) continue;
            float omc = sphere_one_minus_cos(i, dist);
            vec3 l = sample_cone(to_light / dist, omc, rng_next4(rng).xy);
            vec3 f = surface_f_cos(s, v, l);
            float t_light = ray_sphere(p, l, u_point_light_position[i], radius);
            if (any(greaterThan(f, vec3(0.0))) && t_light > 0.0 && !light_blocked(p, l, t_light, cell, rng)) {
                float pdf_light = 1.0 / (2.0 * PI * omc);
                sum += f * sphere_light_radiance(i, dist) * (power_heuristic(pdf_light, surface_pdf(s, v, l)) / pdf_light);
            }
            continue;
        }
        vec3 l = to_light / dist;
        vec3 f = surface_f_cos(s, v, l);
        if (any(greaterThan(f, vec3(0.0))) && !light_blocked(p, l, dist, cell, rng))
            sum += f * u_point_light_intensity[i] * point_falloff(dist, u_point_light_range[i]);
    }
#endif
#if ENV != black
    if (u_env_sampling != 0) {
        float pdf_env;
        vec3 l = sample_environment(rng_next4(rng).xy, pdf_env);
        vec3 f = surface_f_cos(s, v, l);
        if (pdf_env > 0.0 && any(greaterThan(f, vec3(0.0))) && !light_blocked(p, l, 1e30, cell, rng))
            sum += f * env_radiance(l) * (s.occlusion * power_heuristic(pdf_env, surface_pdf(s, v, l)) / pdf_env);
    }
#endif
    return sum;
}

// The light a path brings back to the camera from `hit`, the first surface its ray met.
vec3 path_radiance(vec3 ro, vec3 rd, Hit hit, inout Rng rng) {
    vec3 radiance = vec3(0.0), throughput = vec3(1.0);
    for (int bounce = 1; bounce <= u_max_bounces; ++bounce) {
        vec3 p = ro + rd * hit.t;
        vec3 v = -rd;
        Surface s = make_surface(hit.cell, hit.normal, v);
#if EMISSION
        if (hit.cell.x >= 0) radiance += throughput * surface_emission(s.m, v);
#endif
        radiance += throughput * direct_light(s, p, v, hit.cell, rng);

        vec3 l = surface_sample(s, v, rng_next4(rng).xyz);
        float pdf = surface_pdf(s, v, l);
        if (pdf <= 0.0) break;
        vec3 f = surface_f_cos(s, v, l);
        if (!any(greaterThan(f, vec3(0.0)))) break;
        throughput *= f / pdf;
        Hit next = trace_light(p, l, 1e30, hit.cell, rng);
#if NUM_POINT_LIGHTS > 0
        radiance += throughput * spheres_seen(p, l, next.t < 0.0 ? 1e30 : next.t, pdf);
#endif
        if (next.t < 0.0) {
            radiance += throughput * (environment_seen(l, pdf) * s.occlusion + discs_seen(l, pdf));
            break;
        }
        throughput *= s.occlusion;   // what the next surface sends is indirect light here
        ro = p;
        rd = l;
        hit = next;
    }
    return radiance;
}

#if SHADOW_CATCHER
// A camera path that meets the floor first: the floor's luminance as the spheres leave it and
// as if none stood on it (the same random numbers, so the two are correlated and their ratio
// steady). reference_main.glsl sums both; the pixel's catcher alpha is 1 - sum / sum_open,
// clamped to [0, 1] as the chart's shadow_catcher (light the sphere adds cannot show on a matte).
vec2 g_catcher = vec2(-1.0);   // (L, L_open) of this path; x < 0: it did not meet the floor first
#endif

// One path from the camera: rgb radiance and coverage (1 where the camera ray hits a surface).
vec4 trace_path(vec3 ro, vec3 rd, inout Rng rng) {
    Hit hit = trace_scene(ro, rd, 1e30, SKIP_NONE);
#if SEE_THROUGH
    // The camera sees past a sphere with probability 1 - alpha (its texel at full resolution),
    // as the light does (trace_light).
    if (hit.t >= 0.0 && hit.cell.x >= 0 && rng_next4(rng).x >= sphere_alpha(hit.cell, hit.normal, 1e-20 * u_radius))
        hit = trace_scene(ro, rd, 1e30, hit.cell);
#endif
    if (hit.t < 0.0) {
#if TRANSPARENT
        return vec4(0.0);   // premultiplied, as the chart: misses add no colour, only less coverage
#endif
        return vec4(environment_seen(rd, -1.0) + discs_seen(rd, -1.0), 0.0);
    }
#if SHADOW_CATCHER
    if (hit.cell.x < 0) {
        Rng twin = rng;
        float with_spheres = luminance(path_radiance(ro, rd, hit, rng));
        g_open_floor = true;
        float open = luminance(path_radiance(ro, rd, hit, twin));
        g_open_floor = false;
        g_catcher = vec2(with_spheres, open);
        return vec4(0.0);   // no colour; its coverage comes from the catcher sums
    }
#endif
    return vec4(path_radiance(ro, rd, hit, rng), 1.0);
}
