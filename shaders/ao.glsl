// Ambient occlusion of the IBL term. AO_METHOD analytic: the exact cosine-weighted occlusion
// of each neighbouring sphere (Lagarde & de Rousiers 2014, REFERENCE.md §5), combined as
// prod(1 - occ_i); sdf: taps along the normal, an uncalibrated artistic estimate.
#if AO_METHOD == analytic
#include "sphere_occlusion.glsl"
#if STAGE == cells
// A cell's floor is occluded by its own sphere alone (at the origin); a sphere point sees no
// other sphere.
float ambient_occlusion(vec3 p, vec3 n, ivec2 self_cell) {
    if (self_cell.x >= 0) return 1.0;
    float dist = length(p);
    return 1.0 - sphere_occlusion(dot(n, -p) / dist, max(dist / u_radius, 1.0 + 1e-4));
}

// The share of the ground's specular lobe (seen along v) its cell's sphere hides.
float ground_specular_occlusion(vec3 p, vec3 v, float alpha) {
    float dist = length(p);
    return specular_occlusion(reflect(-v, vec3(0.0, 1.0, 0.0)), -p / dist, asin(min(u_radius / dist, 1.0)), alpha);
}
#else
float ambient_occlusion(vec3 p, vec3 n, ivec2 self_cell) {
    float visible = 1.0;
    ivec2 center = nearest_cell(p);
    for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i) {
            ivec2 cell = center + ivec2(i, j);
            if (any(lessThan(cell, ivec2(0))) || any(greaterThanEqual(cell, u_grid)) || cell == self_cell) continue;
            vec3 to_c = cell_center(cell) - p;
            float dist = length(to_c);
            visible *= 1.0 - sphere_occlusion(dot(n, to_c) / dist, max(dist / u_radius, 1.0 + 1e-4));
        }
    return visible;
}
#endif
#elif AO_METHOD == sdf
uniform int u_ao_taps;
uniform float u_ao_radius;

float ambient_occlusion(vec3 p, vec3 n, ivec2 self_cell) {
    float occ = 0.0;
    float weight = 1.0;
    for (int i = 0; i < u_ao_taps; ++i) {
        float h = 0.01 * u_radius + u_ao_radius * float(i) / float(max(u_ao_taps - 1, 1));
        occ += (h - sdf_scene(p + h * n)) * weight;
        weight *= 0.85;
    }
    return saturate(1.0 - 1.5 * occ / u_ao_radius);
}
#endif
