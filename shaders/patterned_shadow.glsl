// A see-through sphere's shadows in its map's pattern (cells stage, a base colour map with
// alpha). chart_main.glsl mixes the open and the shadowed floor by the share of the light the
// sphere stops on the whole (material.glsl light_coverage), which thins a shadow evenly. The
// reference's rays towards a light meet the sphere where they enter it and pass with one minus
// the alpha there; so each light's shadow here takes the coverage where its central ray enters
// (or passes closest), the map read over the light's cone at that distance: a sharp sun casts
// the pattern, a soft box a blurred one. Needs shade.glsl (lights_brdf_cos) and shadow.glsl.

// The share of a footprint `size` wide (world units) at n_geo that stops light: the map's alpha
// filtered over it (blend, opaque). A mask's cutoff is tested as the camera does where the
// footprint is a texel or less; over two texels or more it is the share of the footprint that
// passes, which the filtered alpha is for a map of 0s and 1s (what a mask's map mostly is):
// the cutoff of a filtered value would draw a soft light's blurred pattern sharp.
float light_alpha(ivec2 cell, vec3 n_geo, float size) {
    float cutoff = cell_texel(cell, 4).a, factor = cell_texel(cell, 2).a;
    float map = base_alpha(n_geo, size, cell);
    if (cutoff < 0.0) return alpha_coverage(cell, factor * map);
    float passing = factor >= cutoff ? map : 0.0;
    return mix(factor * map >= cutoff ? 1.0 : 0.0, passing, saturate(layer_lod(u_base_color_map, size)));
}

// The coverage the ray from p towards l meets on the cell's sphere, over the light's cone.
float shadow_ray_coverage(vec3 p, vec3 l, float angle, ivec2 cell) {
    float t = ray_sphere(p, l, vec3(0.0), u_radius);
    float along = t > 0.0 ? t : max(-dot(p, l), 0.0);   // the entry, or the closest approach
    return light_alpha(cell, normalize(p + l * along), max(2.0 * along * tan(angle), 1e-4 * u_radius));
}

// What to take from the floor the mix left: for each light, its light on the open floor times
// the share of its disc the sphere's silhouette hides, times (the coverage its ray meets - the
// mean coverage the mix used).
vec3 patterned_shadow_correction(vec3 p, vec3 v, ivec2 cell, float stops) {
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
    vec3 taken = vec3(0.0);
#if NUM_DIR_LIGHTS > 0
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i) {
        vec3 l = u_dir_light_direction[i];
        float angle = max(u_dir_light_angular_radius[i], 1e-3);
        float hidden = l.y > 0.0 ? 1.0 - soft_shadow(ro, l, 1.0 / tan(angle)) : 0.0;
        if (hidden > 0.0)
            taken += lights_brdf_cos(m, n, v, l, n_dot_v, u_dir_light_angular_radius[i], e_single, 1.0)
                   * u_dir_light_illuminance[i] * hidden * (shadow_ray_coverage(ro, l, angle, cell) - stops);
    }
#endif
#if NUM_POINT_LIGHTS > 0
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {
        vec3 to_light = u_point_light_position[i] - p;
        float dist = length(to_light);
        vec3 l = to_light / dist;
        float angle = point_angular_radius(i, dist);
        // As shade.glsl: a light nearer than the sphere's near side cannot be hidden by it.
        float visible = angle <= 0.0 ? point_shadow(ro, l, dist)
                      : dist > length(p) - u_radius ? soft_shadow(ro, l, 1.0 / tan(angle)) : 1.0;
        if (visible < 1.0)
            taken += lights_brdf_cos(m, n, v, l, n_dot_v, angle, e_single, 1.0)
                   * u_point_light_intensity[i] * point_falloff(dist, u_point_light_range[i])
                   * (1.0 - visible) * (shadow_ray_coverage(ro, l, max(angle, 1e-4), cell) - stops);
    }
#endif
    return taken;
}
