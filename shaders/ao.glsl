// Ambient occlusion of the IBL term. AO_METHOD analytic: the exact cosine-weighted occlusion
// of each neighbouring sphere (Lagarde & de Rousiers 2014; docs/model.md, geometry), combined as
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

// The sky a cell's sphere hides from floor point p (seen along v), over the sphere's disc, by
// HIDDEN_SKY_SAMPLES directions splitting the disc's solid angle into equal shares (a spiral of
// golden-angle turns, uniform in cos), each read from the prefiltered map at the roughness whose
// lobe is as wide as its share (the GGX lobe's half width at half maximum about the mirror
// direction, 1.287 alpha, matched to a share's RMS angle, its angular radius / sqrt(2): alpha =
// 0.549 radius). One read for the whole disc (its lobe heavy-tailed, reaching sky beside the
// sphere) left the floor 0.0415 mean FLIP from the reference at 256²; 8, 16, 32, 64 shares:
// 0.0390, 0.0368, 0.0342, 0.0336.
// diffuse: the cosine-weighted mean radiance over the disc (the AO's form factor times it is the
// irradiance the sphere hides). specular: the floor's single-scattering specular reflection of
// that sky, the integral over the disc of f cos L (each share its solid angle times f cos L at
// its centre), in place of the lobe's share of the whole sky's reflection.
#if !BUG_FEWTAP_IBL
#if BOUNCE_SPECULAR_SAMPLES > 0
#include "floor_lobe.glsl"
#endif

struct HiddenSky { vec3 diffuse; vec3 specular; };

// The shares keep one size, HIDDEN_SKY_SAMPLES of them where the disc fills the floor's sky (at
// the sphere's foot, cap = 1), fewer as it shrinks (at least HIDDEN_SKY_MIN_SAMPLES): a sun in
// the hidden sky falls in one share or another as the floor point moves, and wide shares
// near the foot turned that into a dark error (white floor, black sphere, the sky preset: the
// floor under the bulge 5.4 % dark with 32 shares at every point; 3.4 % and 2.3 % with 128
// and 256 at the foot, the 1024² default chart's draw as fast).
#define HIDDEN_SKY_MIN_SAMPLES 8

HiddenSky sky_behind_sphere(vec3 p, vec3 v, float alpha) {
    float dist = length(p);
    vec3 axis = -p / dist, t, b;
    basis(axis, t, b);
    float cap = 1.0 - sqrt(max(1.0 - sq(u_radius / dist), 0.0));   // 1 - cos(disc radius)
    int count = clamp(int(ceil(float(HIDDEN_SKY_SAMPLES) * cap)), HIDDEN_SKY_MIN_SAMPLES, HIDDEN_SKY_SAMPLES);
    float share = acos(1.0 - cap / float(count));    // a share's angular radius
    float lod = sqrt(0.549 * share) * u_prefiltered_lods;
    float n_dot_v = max(v.y, MIN_N_DOT_V);   // the floor's normal is +y
    vec3 diffuse = vec3(0.0), specular = vec3(0.0);
    float weight = 0.0;
    for (int k = 0; k < count; ++k) {
        float cos_r = 1.0 - (float(k) + 0.5) / float(count) * cap;
        float phi = GOLDEN_ANGLE * float(k);
        vec3 w = cos_r * axis + sqrt(max(1.0 - cos_r * cos_r, 0.0)) * (cos(phi) * t + sin(phi) * b);
        float c = max(w.y, 0.0);   // the floor's cosine; below its horizon it sees nothing
        vec3 radiance = textureLod(u_prefiltered, w, lod).rgb;
        vec3 h = normalize(w + v);
        float f_cos = d_ggx(max(h.y, 0.0), alpha) * vis_smith_ggx_correlated(c, n_dot_v, alpha)
                    * fresnel_schlick(vec3(DIELECTRIC_F0), saturate(dot(v, h))).x * c;
        diffuse += c * radiance;
        specular += f_cos * radiance;
        weight += c;
    }
    specular *= 2.0 * PI * cap / float(count);
#if BOUNCE_SPECULAR_SAMPLES > 0
    // A lobe narrower than a share is met or missed by the shares' centres by chance (a
    // near-mirror floor, r 0.06: dots under the sphere, its mirror image in the floor missing,
    // the floor under the bulge 13 % bright). There the floor's own lobe samples take it
    // (floor_lobe.glsl), the sky read over each sample's cone: the samples stage_bounce.glsl
    // gives the sphere's light back with, so the two cancel where the sphere looks like the sky.
    float cone_lod = sqrt(0.549 * floor_lobe_cone(alpha, BOUNCE_SPECULAR_SAMPLES)) * u_prefiltered_lods;
    vec3 sampled = vec3(0.0);
    for (int k = 0; k < BOUNCE_SPECULAR_SAMPLES; ++k) {
        FloorLobeSample s = floor_lobe_sample(k, BOUNCE_SPECULAR_SAMPLES, p, v, alpha);
        if (s.weight > 0.0) sampled += s.weight * textureLod(u_prefiltered, s.w, cone_lod).rgb;
    }
    specular = mix(sampled / float(BOUNCE_SPECULAR_SAMPLES), specular, smoothstep(0.5 * share, share, 2.0 * alpha));
#endif
    return HiddenSky(diffuse / max(weight, 1e-6), specular);
}
#endif

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
            // a see-through sphere hides its alpha's share (material.glsl light_coverage)
            visible *= 1.0 - light_coverage(cell) * sphere_occlusion(dot(n, to_c) / dist, max(dist / u_radius, 1.0 + 1e-4));
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
