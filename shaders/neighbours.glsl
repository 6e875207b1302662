// The shared stage's neighbours in a sphere's image-based light, one bounce in closed form:
// each of the 3 x 3 nearest spheres covers a share of the specular lobe (specular_occlusion:
// the specular sky is taken away by that share, not by the AO's) and a cosine-weighted share
// of the sky (sphere_occlusion: the analytic AO takes that share of the diffuse sky away), and
// gives back there the radiance leaving its point that faces the shading point, lit by the
// stage's image-based light and the lights (without its own shadow and occlusion). The
// reference traces these rays; without this term the smooth spheres showed the sky where
// their neighbours stand. In a white furnace (white spheres, uniform sky, no floor) every
// sphere stays at the sky's radiance, as energy conservation wants.
#include "sphere_occlusion.glsl"
#include "sphere_mirror.glsl"

struct NeighbourLight {
    vec3 specular;            // sum of (share of the specular lobe) x radiance
    float lobe_share;         // sum of the shares of the specular lobe
    vec3 irradiance_over_pi;  // sum of (form factor) x radiance: E / pi
};

// Radiance leaving neighbour `cell`'s point q (normal n_q) along w.
vec3 neighbour_radiance(ivec2 cell, vec3 q, vec3 n_q, vec3 w) {
    Material m = cell_material(cell, n_q);
    float n_dot_v = max(dot(n_q, w), MIN_N_DOT_V);
    vec3 dfg = dfg_lookup(n_dot_v, m.perceptual_roughness);
    vec3 r = reflect(-w, n_q);
#if STAGE_PROBE
    r = stage_parallax_from(q, r);
#endif
    vec3 prefiltered = textureLod(u_prefiltered, r, m.perceptual_roughness * u_prefiltered_lods).rgb;
    vec3 radiance = ibl_mix(m, dfg, prefiltered, prefiltered, sh_irradiance(n_q) * INV_PI);
    float e_single = dfg.x + dfg.y;
#if NUM_DIR_LIGHTS > 0
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i)
        radiance += brdf_cos(m, n_q, w, u_dir_light_direction[i], n_dot_v, u_dir_light_angular_radius[i], e_single)
                  * u_dir_light_illuminance[i];
#endif
#if NUM_POINT_LIGHTS > 0
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {
        vec3 to_light = u_point_light_position[i] - q;
        float dist = length(to_light);
        radiance += brdf_cos(m, n_q, w, to_light / dist, n_dot_v, point_angular_radius(i, dist), e_single)
                  * u_point_light_intensity[i] * point_falloff(dist, u_point_light_range[i]);
    }
#endif
    return radiance;
}

// The 3 x 3 spheres around a sphere point's own `cell`.
NeighbourLight neighbour_light(vec3 p, vec3 n, vec3 r, float alpha, ivec2 self_cell) {
    NeighbourLight light = NeighbourLight(vec3(0.0), 0.0, vec3(0.0));
    for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i) {
            ivec2 cell = self_cell + ivec2(i, j);
            if (any(lessThan(cell, ivec2(0))) || any(greaterThanEqual(cell, u_grid)) || cell == self_cell) continue;
            vec3 to_c = cell_center(cell) - p;
            float dist = length(to_c);
            vec3 dir = to_c / dist;
            float lobe = specular_occlusion(r, dir, asin(min(u_radius / dist, 1.0)), alpha);
            float form = sphere_occlusion(dot(n, dir), max(dist / u_radius, 1.0 + 1e-4));
            vec3 radiance = neighbour_radiance(cell, cell_center(cell) - dir * u_radius, -dir, -dir);
            light.specular += lobe * radiance;
            light.lobe_share += lobe;
            light.irradiance_over_pi += form * radiance;
        }
    return light;
}

// A sphere of material m seen from afar along w, lit by a distant light (direction l,
// illuminance e): the mean radiance of its diffuse body over its disc (sphere_mean_radiance).
vec3 sphere_mean_light(Material m, vec3 w, vec3 l, vec3 e) {
    float cos_a = clamp(dot(w, l), -1.0, 1.0);
    float a = acos(cos_a);
    float phase = (2.0 / 3.0) * (sin(a) + (PI - a) * cos_a) / PI;
    float f_cos = sqrt(0.5 * (1.0 + cos_a));
    return (1.0 - m.metallic) * diffuse_lobe(m, f_cos) * phase * e;
}

// A sphere seen from afar along w: the mean radiance over its disc, in closed form, but for its
// highlights (sphere_mirror.glsl gives the floor those as the mirror image near the sphere).
// - A distant light (direction l, illuminance E) on its diffuse body: a Lambert sphere's,
//   (2/3)(sin a + (pi - a) cos a) / pi of the radiance where the light falls square on
//   (a: the phase angle, between w and l).
// - The environment: the body's irradiance facing w, and the specular layer's mean over all
//   directions (the irradiance's constant term / pi) with F at its mean over a mirror ball's
//   normals (f0 + (1 - f0) / 21: Schlick's F at cos 0.456).
// A sphere seen from close by shows less than a hemisphere: this is the far view.
vec3 sphere_mean_radiance(ivec2 cell, vec3 w) {
    Material m = cell_material(cell, w);
    vec3 radiance = (1.0 - m.metallic) * diffuse_lobe(m, 1.0) * sh_irradiance(w) + sphere_fresnel(m, 0.456) * u_sh[0] * INV_PI;
#if NUM_DIR_LIGHTS > 0
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i)
        radiance += sphere_mean_light(m, w, u_dir_light_direction[i], u_dir_light_illuminance[i]);
#endif
#if NUM_POINT_LIGHTS > 0
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {   // as a distant light from the sphere's centre
        vec3 to_light = u_point_light_position[i] - cell_center(cell);
        float dist = length(to_light);
        radiance += sphere_mean_light(m, w, to_light / dist,
                                      u_point_light_intensity[i] * point_falloff(dist, u_point_light_range[i]));
    }
#endif
    return radiance;
}

// The floor's light from the 3 x 3 spheres around its point p's nearest, where the AO took
// their share of its sky away: each sphere's mean radiance over the disc it shows, the far
// view (a floor point sees more of a sphere than a neighbour does, whose facing point stands
// for it there), and its mirror image of the lights (sphere_mirror.glsl; the far view's even
// spread lit the spheres' shadows with a grazing reflection that does not reach them). The
// diffuse bounce alone: adding the spheres' mean radiance to the floor's specular lobe
// measured worse (shared stage, 256², 0.0781 -> 0.0790 mean FLIP).
vec3 floor_sphere_irradiance_over_pi(vec3 p, vec3 n) {
    vec3 sum = vec3(0.0);
    ivec2 centre = nearest_cell(p);
    for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i) {
            ivec2 cell = centre + ivec2(i, j);
            if (any(lessThan(cell, ivec2(0))) || any(greaterThanEqual(cell, u_grid))) continue;
            vec3 to_c = cell_center(cell) - p;
            float dist = length(to_c);
            vec3 dir = to_c / dist;
            sum += light_coverage(cell) * (sphere_occlusion(dot(n, dir), max(dist / u_radius, 1.0 + 1e-4))
                 * sphere_mean_radiance(cell, -dir)
                 + sphere_reflected_light(p, cell_center(cell), cell_material(cell, -dir)) * INV_PI);
        }
    return sum;
}
