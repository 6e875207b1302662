#include "hammersley.glsl"

// The cells stage's bounce cache (BOUNCE_CACHE): the light a cell's sphere bounces onto its
// own floor, as the floor sends it back up (its diffuse radiance, albedo / pi times the
// irradiance from the sphere, and its glossy reflection of the sphere: the sphere's image in
// the floor, which the stage probe's floor lacks), kept per cell on a tile over the whole
// floor plane. The plan
// draws it `bounce_iterations` times (bounce_cache_main.glsl), each time with the sphere lit
// by the last one: sky -> floor -> sphere -> floor -> ... one round trip more per draw, so the
// series converges as the preset's effort grows. The sphere reads it here (bounce_gather), the
// floor's bounce prepass through the sphere it shades.
//
// A tile of u_bounce_cache_tile texels a side per cell (tile origin cell * tile, as the bounce
// prepass's). Floor point (x, z) (from the sphere's axis) sits at a = x / (R + |x|) in (-1, 1)
// on each axis: texels 2 R / tile apart at the contact (R / 8 at default's 16, R / 16 at
// high's 32), wider as the bounce fades (as (R / d)^3), and the whole plane on the tile.
uniform sampler2D u_bounce_cache;
uniform int u_bounce_cache_tile;
uniform bool u_bounce_cache_drawn;   // false before the first draw: nothing to read yet

// A bounce ray's sphere point (in the cache's and the bounce prepass's draws) reads the cache
// from fewer directions: it carries the later round trips, a few per cent of the light, and
// it is shaded BOUNCE_RAYS times per texel (the gather's reads were most of a cache draw).
#define BOUNCE_RAY_GATHER_SAMPLES max(BOUNCE_GATHER_SAMPLES / 4, 2)

vec2 bounce_cache_warp(vec2 xz) { return xz / (u_radius + abs(xz)); }

// The floor point a cache texel centre stands for (bounce_cache_main.glsl).
vec3 bounce_cache_point(vec2 texel_in_tile) {
    vec2 a = (texel_in_tile + 0.5) * (2.0 / float(u_bounce_cache_tile)) - 1.0;
    vec2 xz = u_radius * a / (1.0 - abs(a));
    return vec3(xz.x, u_ground_y, xz.y);
}

// The cached bounce radiance where the ray from `origin` along `d` meets the floor (0 above it).
vec3 floor_bounce_along(vec3 origin, vec3 d, ivec2 cell) {
    if (d.y >= -1e-4) return vec3(0.0);
    vec3 q = origin + d * ((u_ground_y - origin.y) / d.y);
    float tile = float(u_bounce_cache_tile);
    vec2 at = clamp((bounce_cache_warp(q.xz) * 0.5 + 0.5) * tile, vec2(0.5), vec2(tile - 0.5));
    return texture(u_bounce_cache, (vec2(cell) * tile + at) / vec2(textureSize(u_bounce_cache, 0))).rgb;
}

// The light the sphere's point p (normal n, seen along v, material m, dfg its LUT entry) gets
// back from its floor's bounce: the cosine-weighted mean over the directions that meet the
// floor (the diffuse) and the GGX lobe's mean about the mirror direction (the specular), each
// from `samples` fixed Hammersley directions, weighed by the material as the split sum weighs
// the environment (ibl_mix).
vec3 bounce_gather(Material m, vec3 p, vec3 n, vec3 v, vec3 dfg, ivec2 cell, int samples) {
    if (!u_bounce_cache_drawn) return vec3(0.0);
    vec3 r = reflect(-v, n);
    // A point facing up sees the floor only near its horizon, and its mirror ray goes up: the
    // bounce there is under what 8 bits show (n.y 0.75: the floor fills 1 % of the cosine).
    if (n.y > 0.75 && r.y >= 0.0) return vec3(0.0);
    vec3 t, b;
    basis(n, t, b);
    vec3 diffuse = vec3(0.0), specular = vec3(0.0);
    float specular_weight = 0.0;
    uint count = uint(samples);
    for (uint i = 0u; i < count; ++i) {
        vec2 u = hammersley(i, count);
        float s = sqrt(u.x), phi = 2.0 * PI * u.y;
        vec3 d = s * (cos(phi) * t + sin(phi) * b) + sqrt(max(1.0 - u.x, 0.0)) * n;   // pdf cos / pi
        diffuse += floor_bounce_along(p, d, cell);
        vec3 h_local = ggx_half_vector(u, m.alpha);
        vec3 h = h_local.x * t + h_local.y * b + h_local.z * n;
        vec3 l = reflect(-v, h);
        float n_dot_l = dot(n, l);
        if (n_dot_l > 0.0) {   // the prefilter's weighting (prefilter_main.glsl)
            specular += floor_bounce_along(p, l, cell) * n_dot_l;
            specular_weight += n_dot_l;
        }
    }
    diffuse /= float(count);
    specular = specular_weight > 0.0 ? specular / specular_weight : vec3(0.0);
    return ibl_mix(m, dfg, specular, specular, diffuse);
}
