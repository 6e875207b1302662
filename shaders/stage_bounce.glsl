#include "sphere_occlusion.glsl"
#include "ray_sphere.glsl"

// Cells stage: the light a cell's sphere sends onto its own floor point q (seen along v). The
// sphere hides a form factor FF of the floor's sky (the AO removed that part of the
// environment term); in its place the floor receives the sphere's radiance. Its cosine-weighted
// average over the sphere's visible cap is estimated from BOUNCE_RAYS rays (the cap's axis, then
// a ring at BOUNCE_RING of its angular radius); a Lambert floor then returns rho FF L_avg.
#define BOUNCE_RING 0.6
#define BOUNCE_MIN_FF 1e-3   // far floor: the sphere's light is below what 8 bits show
#define BOUNCE_FEW_FF 0.05   // below this the sphere is small in the floor's sky: its axis ray will do

vec3 sphere_bounce(vec3 q, vec3 v, ivec2 cell, float pixel_size) {
    float dist = length(q);
    float ff = sphere_occlusion(-q.y / dist, max(dist / u_radius, 1.0 + 1e-4));
    if (ff < BOUNCE_MIN_FF) return vec3(0.0);
    vec3 axis = -q / dist;
    vec3 t, b;
    basis(axis, t, b);
    float ring = BOUNCE_RING * asin(min(u_radius / dist, 1.0));
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    int rays = ff < BOUNCE_FEW_FF ? 1 : BOUNCE_RAYS;
    for (int i = 0; i < rays; ++i) {
        float phi = 2.0 * PI * float(i) / float(max(BOUNCE_RAYS - 1, 1));
        vec3 w = i == 0 ? axis : cos(ring) * axis + sin(ring) * (cos(phi) * t + sin(phi) * b);
        float cos_q = w.y;                       // the floor's normal is +y
        if (cos_q <= 0.0) continue;              // below the floor's horizon
        float th = ray_sphere(q, w, vec3(0.0), u_radius);
        if (th <= 0.0) continue;
        vec3 s = q + w * th;
        sum += cos_q * shade_sphere_for_bounce(s, s / u_radius, -w, cell, pixel_size, ring);
        weight += cos_q;
    }
    if (weight <= 0.0) return vec3(0.0);
    Material floor_material = ground_material();
    vec3 dfg = dfg_lookup(max(v.y, MIN_N_DOT_V), floor_material.perceptual_roughness);
    vec3 albedo = floor_material.base_color_linear * dfg.z * ff;
#if AO_METHOD == analytic && !BUG_FEWTAP_IBL
    // The specular share the sphere hides (shade.glsl) comes back as its light too.
    float so = ground_specular_occlusion(q, v, floor_material.alpha);
    albedo += (DIELECTRIC_F0 * dfg.x + dfg.y) * energy_compensation(vec3(DIELECTRIC_F0), dfg.x + dfg.y) * so;
#endif
    return albedo * sum / weight;
}
