#include "sphere_occlusion.glsl"
#include "ray_sphere.glsl"
#include "sphere_mirror.glsl"
#include "bounce_split.glsl"
#include "lobe_read.glsl"
#include "floor_lobe.glsl"

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
// The rays carry the smooth part (the diffuse, a rough sphere's reflections); a smooth sphere's
// reflection of the punctual lights and of the stage -- a few rays would find its tiny
// highlights or miss them, drawing blobs on the floor -- comes in closed form
// (sphere_reflected_light, sphere_reflected_sky).
#define BOUNCE_RING_X 0.6666667   // Radau's ring, and its weight (the axis has the rest)
#define BOUNCE_RING_WEIGHT 0.75
#define BOUNCE_MIN_FF 1e-3   // far floor: the sphere's light is below what 8 bits show
#define BOUNCE_FEW_FF 0.05   // below this the sphere is small in the floor's sky: its axis ray will do

#if BOUNCE_MIRROR_DIRECTIONS > 0
// The irradiance at floor point q (from the sphere's centre) from the sphere of material m
// mirroring the sky: every direction of the probe above the floor's horizon a parallel beam,
// as a light is, BOUNCE_MIRROR_DIRECTIONS of them spread evenly over the sky down to the
// ramp below the horizon where the rays take over (a spiral, equal solid angles), each the
// probe averaged over its share (the prefiltered level whose lobe is that wide: alpha^2 ~
// share / 4 pi) and seen over the share's width. A few bounce rays read a polished sphere's
// mirror image of the studio's boxes at a few points: the floor beside it, under the fill
// box's image, was 7 % bright (now 3 % dark). The default chart's mean FLIP with 0, 8, 16, 32
// directions: 0.0289, 0.0278, 0.0277, 0.0276. The floor the sphere mirrors stays with the rays
// (shade.glsl), whose hit points see it from where they are: as beams from afar, the probe's
// lit far floor lit a mirror's own umbra at twice the reference's light (read from the mirror
// point, 1.45x: the probe's floor lacks the cell's own bounce, which lights the floor the
// sphere mirrors most).
vec3 sphere_reflected_sky(vec3 q, Material m) {
    float share = 2.0 * PI * (1.0 + MIRRORED_SKY_RAMP) / float(BOUNCE_MIRROR_DIRECTIONS);
    float lod = sqrt(sqrt(share * (0.25 * INV_PI))) * u_prefiltered_lods;   // r = sqrt(alpha)
    float width = sqrt(share * INV_PI) + m.alpha;   // the share's angular radius, blurred by the lobe
    vec3 sum = vec3(0.0);
    for (int k = 0; k < BOUNCE_MIRROR_DIRECTIONS; ++k) {
        vec3 l = spiral_direction(k, BOUNCE_MIRROR_DIRECTIONS, -MIRRORED_SKY_RAMP);
        float cos_i;
        float e = mirror_irradiance(q, l, width, cos_i);
        if (e > 0.0) sum += mirror_fresnel(m, cos_i) * textureLod(u_prefiltered, l, lod).rgb * (e * mirrored_sky_share(l.y));
    }
    return sum * share;
}
#endif

// specular_samples (a constant at each call): how many samples of the floor's lobe take its
// specular reflection of the sphere towards v (0: only what the floor sends every way, its
// diffuse).
vec3 sphere_bounce_toward(vec3 q, vec3 v, ivec2 cell, float pixel_size, int specular_samples) {
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
#if USE_TEXTURES
    // The closed-form mirror images take one material for the sphere: its maps' at the point
    // nearest q (a textured metal's roughness and colour are its maps', not its factors').
    apply_texels(sphere_material, cell, sample_surface(axis, pixel_size, cell));
#endif
    float resolved = bounce_resolves(sphere_material.alpha);
    Material floor_material = ground_material();
    float n_dot_v = max(v.y, MIN_N_DOT_V);   // the floor's normal is +y
    vec3 sum = vec3(0.0), specular = vec3(0.0);
    float weight = 0.0;
    int rays = ff < BOUNCE_FEW_FF ? 1 : BOUNCE_RAYS;
#if AO_METHOD == analytic && !BUG_FEWTAP_IBL
    // The floor's specular reflection of the sphere: samples of its lobe (floor_lobe.glsl),
    // each that meets the sphere reading the sphere's whole light there, its reflections too
    // (the rays leave a smooth sphere's to the closed form, which lights the floor's diffuse
    // only: a polished metal's image in a glossy floor was missing).
    int lobe_samples = specular_samples;
#else
    int lobe_samples = 0;
#endif
    for (int i = 0; i < rays + lobe_samples; ++i) {
        bool lobe = i >= rays;
        vec3 w;
        float share;
        if (!lobe) {
            float phi = 2.0 * PI * float(i) / float(max(BOUNCE_RAYS - 1, 1));
            w = i == 0 ? axis : ring_cos * axis + ring_sin * (cos(phi) * t + sin(phi) * b);
            share = i == 0 ? (rays == 1 ? 1.0 : 1.0 - BOUNCE_RING_WEIGHT) : BOUNCE_RING_WEIGHT / float(rays - 1);
        } else {
#if AO_METHOD == analytic && !BUG_FEWTAP_IBL
            FloorLobeSample sample_k = floor_lobe_sample(i - rays, lobe_samples, q, v, floor_material.alpha);
            w = sample_k.on_sphere;
            share = sample_k.weight;
#endif
        }
        float cos_q = w.y;                       // the floor's normal is +y
        if (cos_q <= 0.0 || share <= 0.0) continue;   // below the floor's horizon
        float th = ray_sphere(q, w, vec3(0.0), u_radius);
        if (th <= 0.0) continue;
        vec3 s = q + w * th;
        // A lobe sample sees the sphere's reflections blurred over its cone (alpha ~ half of it).
        g_reflection_blur = lobe ? sqrt(0.5 * floor_lobe_cone(floor_material.alpha, lobe_samples)) : 0.0;
        // Its lights' highlights only in the share a few samples resolve (a polished sphere's
        // is a spike they meet or miss by chance: the floor beside a mirror under a sun read
        // 4 % bright, against 3.7 % allowed); its reflections of the sky and the floor in full.
        vec3 radiance = shade_sphere_for_bounce(s, s / u_radius, -w, cell, pixel_size,
                                                lobe ? floor_material.alpha : spacing, resolved);
        if (lobe) {
            specular += share * radiance;
        } else {
            sum += share * cos_q * radiance;
            weight += share * cos_q;
        }
    }
    vec3 dfg = dfg_lookup(n_dot_v, floor_material.perceptual_roughness);
    vec3 mirrored = vec3(0.0);
    if (resolved < 1.0) {
        mirrored = sphere_reflected_light(q, vec3(0.0), sphere_material);
#if BOUNCE_MIRROR_DIRECTIONS > 0
        mirrored += sphere_reflected_sky(q, sphere_material);
#endif
    }
    mirrored *= 1.0 - resolved;
#if CLEARCOAT
    // A coat's image of the lights and the sky, as a mirror ball's with the coat's Fresnel
    // (f0 0.04) times its weight, but for the share the rays resolve (its roughness). Left to
    // the rays alone, the coated spheres' floor in front of them read 1-1.6 % dark at high.
    float coat_resolved = bounce_resolves(sphere_material.clearcoat_alpha);
    if (sphere_material.clearcoat > 0.0 && coat_resolved < 1.0) {
        Material coat = make_material(vec3(DIELECTRIC_F0), 1.0, sphere_material.clearcoat_perceptual_roughness);
        vec3 coat_mirrored = sphere_reflected_light(q, vec3(0.0), coat);
#if BOUNCE_MIRROR_DIRECTIONS > 0
        coat_mirrored += sphere_reflected_sky(q, coat);
#endif
        mirrored += (sphere_material.clearcoat * (1.0 - coat_resolved)) * coat_mirrored;
    }
#endif
    vec3 reflected = floor_material.base_color_linear * dfg.z * INV_PI * mirrored;
    if (weight <= 0.0) return reflected;
    vec3 albedo = floor_material.base_color_linear * dfg.z * ff;
#if AO_METHOD == analytic && !BUG_FEWTAP_IBL
    // The specular the sphere hides (shade.glsl takes the sky's f cos L over its disc away,
    // ao.glsl sky_behind_sphere) comes back as the sphere's own, the same integral over its
    // radiance where the floor's lobe meets it.
    specular *= energy_compensation(vec3(DIELECTRIC_F0), dfg.x + dfg.y) / float(max(lobe_samples, 1));
#endif
    return albedo * sum / weight + specular + reflected;
}

vec3 sphere_bounce(vec3 q, vec3 v, ivec2 cell, float pixel_size) {
    return sphere_bounce_toward(q, v, cell, pixel_size, BOUNCE_SPECULAR_SAMPLES);
}
