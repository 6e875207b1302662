#include "sphere_occlusion.glsl"
#include "ray_sphere.glsl"

// Cells stage: the light a cell's sphere sends onto its own floor point q (seen along v). The
// sphere hides a form factor FF of the floor's sky (the AO removed that part of the
// environment term); in its place the floor receives the sphere's radiance. Its cosine-weighted
// average over the sphere's visible cap is estimated from BOUNCE_RAYS rays (the cap's axis, then
// a ring at BOUNCE_RING of its angular radius); a Lambert floor then returns rho FF L_avg.
// The rays carry the smooth part (environment, the lights' diffuse share); the sphere's
// reflection of the punctual lights -- a few rays would find a smooth sphere's tiny highlight or
// miss it, drawing blobs on the floor -- comes in closed form (sphere_reflected_light).
#define BOUNCE_RING 0.6
#define BOUNCE_MIN_FF 1e-3   // far floor: the sphere's light is below what 8 bits show
#define BOUNCE_FEW_FF 0.05   // below this the sphere is small in the floor's sky: its axis ray will do

// Irradiance at floor point q from the sphere's specular reflection of the punctual lights. A
// mirror ball of radius R under illuminance E reflects intensity E R^2 F / 4 into every direction
// u (a parallel beam spreads evenly; F at the incidence that turns l into u, cos = sqrt((1 +
// l.u) / 2)); a rough sphere blurs that even spread without changing it much. Seen from q at
// distance d, under the floor's cosine: E_q = E R^2 F cos_q / (4 d^2).
// m: the cell's material.
vec3 sphere_reflected_light(vec3 q, Material m) {
    float dist = length(q);
    vec3 u = q / dist;                  // from the sphere's centre towards q
    float cos_q = -u.y;                 // the floor's normal is +y; q sees the centre along -u
    if (cos_q <= 0.0) return vec3(0.0);
    vec3 sum = vec3(0.0);
#if NUM_DIR_LIGHTS > 0
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i)
        sum += sphere_fresnel(m, sqrt(saturate(0.5 * (1.0 + dot(u_dir_light_direction[i], u)))))
             * u_dir_light_illuminance[i];
#endif
#if NUM_POINT_LIGHTS > 0
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {
        float d_light = length(u_point_light_position[i]);
        vec3 l = u_point_light_position[i] / max(d_light, 1e-6);
        sum += sphere_fresnel(m, sqrt(saturate(0.5 * (1.0 + dot(l, u)))))
             * u_point_light_intensity[i] * point_falloff(d_light, u_point_light_range[i]);
    }
#endif
    return sum * (0.25 * sq(u_radius / dist) * cos_q);
}

// The share of the lights' reflection the rays resolve: across the cap, the rays' hit points'
// reflected directions lie about a radian apart, so a lobe narrower than that (alpha below
// ~0.5) shows as blobs where a ray happens to find its highlight; the closed form takes it.
#define BOUNCE_LOBE_FROM 0.1
#define BOUNCE_LOBE_TO 0.5
float bounce_resolves(float alpha) {
    return smoothstep(BOUNCE_LOBE_FROM, BOUNCE_LOBE_TO, alpha);
}

vec3 sphere_bounce(vec3 q, vec3 v, ivec2 cell, float pixel_size) {
    float dist = length(q);
    float ff = sphere_occlusion(-q.y / dist, max(dist / u_radius, 1.0 + 1e-4));
    if (ff < BOUNCE_MIN_FF) return vec3(0.0);
    vec3 axis = -q / dist;
    vec3 t, b;
    basis(axis, t, b);
    float ring = BOUNCE_RING * asin(min(u_radius / dist, 1.0));
    Material sphere_material = cell_material(cell, axis);
    float resolved = bounce_resolves(sphere_material.alpha);
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
        sum += cos_q * shade_sphere_for_bounce(s, s / u_radius, -w, cell, pixel_size, ring, resolved);
        weight += cos_q;
    }
    Material floor_material = ground_material();
    vec3 dfg = dfg_lookup(max(v.y, MIN_N_DOT_V), floor_material.perceptual_roughness);
    vec3 reflected = floor_material.base_color_linear * dfg.z * INV_PI * sphere_reflected_light(q, sphere_material)
                   * (1.0 - resolved);
    if (weight <= 0.0) return reflected;
    vec3 albedo = floor_material.base_color_linear * dfg.z * ff;
#if AO_METHOD == analytic && !BUG_FEWTAP_IBL
    // The specular share the sphere hides (shade.glsl) comes back as its light too.
    float so = ground_specular_occlusion(q, v, floor_material.alpha);
    albedo += (DIELECTRIC_F0 * dfg.x + dfg.y) * energy_compensation(vec3(DIELECTRIC_F0), dfg.x + dfg.y) * so;
#endif
    return albedo * sum / weight + reflected;
}
