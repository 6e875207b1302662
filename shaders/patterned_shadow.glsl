// A see-through sphere's shadows in its map's pattern on the cells stage (a base colour map
// with alpha). chart_main.glsl mixes the open and the shadowed floor by the share of the light
// the sphere stops on the whole (material.glsl light_coverage), which would thin a shadow
// evenly; each light's shadow here takes instead the coverage its ray meets
// (material.glsl light_ray_coverage). Needs shade.glsl (lights_brdf_cos) and shadow.glsl.

// What to take from the floor the mix left: for each light, its light on the open floor times
// the share of its disc the sphere's silhouette hides, times (the coverage its ray meets - the
// mean coverage the mix used), averaged over the pixel's footprint as the floor's shadow is
// (shadow.glsl footprint_shadow).
vec3 patterned_shadow_correction(vec3 p, vec3 v, ivec2 cell, float stops, float pixel_size) {
    Material m = ground_material();
    vec3 n = vec3(0.0, 1.0, 0.0);
#if BUG_UNCLAMPED_NDOTV
    float n_dot_v = v.y;
#else
    float n_dot_v = max(v.y, MIN_N_DOT_V);
#endif
    vec3 dfg = dfg_lookup(n_dot_v, m.perceptual_roughness);
    float e_single = dfg.x + dfg.y;
    vec3 ro = p + n * (1e-3 * u_radius);
    vec3 ex, ey;
    floor_footprint(v, pixel_size, ex, ey);
    vec3 taken = vec3(0.0);
#if NUM_DIR_LIGHTS > 0
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i) {
        vec3 l = u_dir_light_direction[i];
        if (l.y <= 0.0) continue;
        float angle = max(u_dir_light_angular_radius[i], 1e-3);
        float share = 0.0;   // the footprint's mean of hidden x (coverage - stops)
        for (int k = 0; k < 4; ++k) {
            vec3 o = ro + footprint_offset(k, ex, ey);
            float hidden = 1.0 - disc_visibility(o, l, angle, vec3(0.0));
            if (hidden > 0.0) share += hidden * (light_ray_coverage(cell, vec3(0.0), o, l, angle) - stops);
        }
        if (share != 0.0)
            taken += lights_brdf_cos(m, n, v, l, n_dot_v, u_dir_light_angular_radius[i], e_single, 1.0, false)
                   * u_dir_light_illuminance[i] * (0.25 * share);
    }
#endif
#if NUM_POINT_LIGHTS > 0
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {
        vec3 to_light = u_point_light_position[i] - p;
        float dist = length(to_light);
        vec3 l = to_light / dist;
        float angle = point_angular_radius(i, dist);
        float share = 0.0;
        for (int k = 0; k < 4; ++k) {
            vec3 o = footprint_offset(k, ex, ey);
            float visible = point_light_visibility(ro + o, p + o, l, dist, angle);
            if (visible < 1.0)
                share += (1.0 - visible) * (light_ray_coverage(cell, vec3(0.0), ro + o, l, max(angle, 1e-4)) - stops);
        }
        if (share != 0.0)
            taken += lights_brdf_cos(m, n, v, l, n_dot_v, angle, e_single, 1.0, false)
                   * u_point_light_intensity[i] * point_falloff(dist, u_point_light_range[i]) * (0.25 * share);
    }
#endif
    return taken;
}
