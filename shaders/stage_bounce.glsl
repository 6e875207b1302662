#include "sphere_occlusion.glsl"
#include "ray_sphere.glsl"

// Cells stage: the light a cell's sphere sends onto its own floor point q (seen along v). The
// sphere hides a form factor FF of the floor's sky (the AO removed that part of the
// environment term); in its place the floor receives the sphere's radiance. Its cosine-weighted
// average over the sphere's visible cap is estimated from BOUNCE_RAYS rays by Gauss-Radau on
// the cap's solid angle (x = (1 - cos) / (1 - cos of the cap's radius), uniform on [0, 1]):
// the axis with weight 1/4 and a ring at x = 2/3 with 3/4, exact for radiance quadratic in x.
// The sphere is brighter towards its limb as seen from the floor (it sees more sky there, and
// Fresnel rises); uniform sky, rough orange sphere, the floor's bounce against the reference in
// front of the sphere: 0.84-0.90 with equal weights and the ring at 0.6 of the cap's angular
// radius, 0.91-0.98 with these (what is left: the sphere's light the floor sends back to the
// sphere, which the stage probe lacks, about +5 %). A Lambert floor then returns rho FF L_avg.
// The rays carry the smooth part (environment, the lights' diffuse share); the sphere's
// reflection of the punctual lights -- a few rays would find a smooth sphere's tiny highlight or
// miss it, drawing blobs on the floor -- comes in closed form (sphere_reflected_light).
#define BOUNCE_RING_X 0.6666667   // Radau's ring, and its weight (the axis has the rest)
#define BOUNCE_RING_WEIGHT 0.75
#define BOUNCE_MIN_FF 1e-3   // far floor: the sphere's light is below what 8 bits show
#define BOUNCE_FEW_FF 0.05   // below this the sphere is small in the floor's sky: its axis ray will do

// Irradiance at floor point q from the sphere's specular reflection of the punctual lights, as
// a mirror ball's: a parallel beam (illuminance E, from direction l) reflects off the point s
// = R n whose normal n is halfway between l and the direction from s to q (found by fixed-point
// steps from the far field's). A convex mirror's reflected beam diverges from two focal lines
// (astigmatic: R cos(i) / 2 and R / (2 cos(i)) behind s, i the incidence), so at distance D from
// s it carries E F f_t f_s / ((D + f_t)(D + f_s)) = E F R^2 / (4 (D + f_t)(D + f_s)) across
// the ray; the far field's E R^2 F / (4 d^2) is its limit. A rough sphere blurs that without
// changing it much. Near the sphere the far field misplaces the light: behind the sphere (its
// shadow) the mirror point is on the side q cannot see (under the key light alone the shadow's
// core read 1.3-1.9x the reference with the far field), and a beam not yet spread is brighter.
// The image is seen in the share of it (widened by `spread`: the light's angular radius and the
// lobe's) above s's tangent plane as q sees it.
#define MIRROR_POINT_STEPS 3

// The light's irradiance at q per unit illuminance and Fresnel; cos_i: the incidence at s.
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

// m: the cell's material.
vec3 sphere_reflected_light(vec3 q, Material m) {
    vec3 sum = vec3(0.0);
    float cos_i;
#if NUM_DIR_LIGHTS > 0
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i) {
        float e = mirror_irradiance(q, u_dir_light_direction[i], u_dir_light_angular_radius[i] + m.alpha, cos_i);
        sum += sphere_fresnel(m, cos_i) * u_dir_light_illuminance[i] * e;
    }
#endif
#if NUM_POINT_LIGHTS > 0
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {
        float d_light = length(u_point_light_position[i]);
        vec3 l = u_point_light_position[i] / max(d_light, 1e-6);
        float e = mirror_irradiance(q, l, m.alpha, cos_i);
        sum += sphere_fresnel(m, cos_i) * u_point_light_intensity[i] * point_falloff(d_light, u_point_light_range[i]) * e;
    }
#endif
    return sum;
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
    float cap = 1.0 - sqrt(max(1.0 - sq(u_radius / dist), 0.0));   // 1 - cos(the cap's angular radius)
    float ring_cos = 1.0 - BOUNCE_RING_X * cap;
    float ring_sin = sqrt(max(1.0 - ring_cos * ring_cos, 0.0));
    float spacing = acos(ring_cos);   // the rays' spacing, which the lights' highlights are spread over
    Material sphere_material = cell_material(cell, axis);
    float resolved = bounce_resolves(sphere_material.alpha);
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    int rays = ff < BOUNCE_FEW_FF ? 1 : BOUNCE_RAYS;
    for (int i = 0; i < rays; ++i) {
        float phi = 2.0 * PI * float(i) / float(max(BOUNCE_RAYS - 1, 1));
        vec3 w = i == 0 ? axis : ring_cos * axis + ring_sin * (cos(phi) * t + sin(phi) * b);
        float share = i == 0 ? (rays == 1 ? 1.0 : 1.0 - BOUNCE_RING_WEIGHT) : BOUNCE_RING_WEIGHT / float(rays - 1);
        float cos_q = w.y;                       // the floor's normal is +y
        if (cos_q <= 0.0) continue;              // below the floor's horizon
        float th = ray_sphere(q, w, vec3(0.0), u_radius);
        if (th <= 0.0) continue;
        vec3 s = q + w * th;
        sum += share * cos_q * shade_sphere_for_bounce(s, s / u_radius, -w, cell, pixel_size, spacing, resolved);
        weight += share * cos_q;
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
