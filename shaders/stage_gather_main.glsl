#include "common.glsl"
#include "loop_guard.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "camera.glsl"
#include "surface_shading.glsl"
#include "ray_sphere.glsl"

// The cells stage's gather prepass (GATHER_PREPASS): what each cell's sphere gets back from its
// floor's bounce cache (bounce_cache.glsl bounce_gather), on a grid of texels u_gather_step
// cell pixels apart (half the bounce prepass's: near the sphere's foot it changes faster than
// the floor's bounce), a tile per cell over the prepass's extent, drawn over the sphere's box
// and interpolated by the chart. Per pixel the gather's 2 x BOUNCE_GATHER_SAMPLES reads of the cache cost a
// 512² default chart 40 % of its draw on llvmpipe; what it reads varies over the floor's
// scale, not a pixel's. Texels whose ray passes the sphere by take the sphere's point nearest
// the ray, so that the interpolation runs on smoothly up to the silhouette.
layout(location = 0) out vec4 out_gather;
uniform vec2 u_prepass_origin;
uniform ivec2 u_gather_tile;
uniform float u_gather_step;

void gather_prepass_texel() {
    vec2 position = prepass_grid_position(ivec2(gl_FragCoord.xy), u_gather_tile, u_gather_step, u_prepass_origin,
                                          g_cell);
    vec3 rd;
    vec3 ro = camera_ray(2.0 * position / u_resolution - 1.0, rd);
    float t = ray_sphere(ro, rd, vec3(0.0), u_radius);
    vec3 n = normalize(t > 0.0 ? ro + rd * t : ro + rd * max(dot(-ro, rd), 0.0));
    vec2 footprint = pixel_footprint();
    // The point as shade_point sees it: the cell's maps applied (material, normal).
    Surface s = surface_at(n * u_radius, n, -rd, g_cell, footprint.x + footprint.y * max(t, 0.0), false);
    out_gather = vec4(bounce_gather(s.m, s.p, s.n, s.v, s.dfg, g_cell, BOUNCE_GATHER_SAMPLES), 1.0);
}

void main() {
    gather_prepass_texel();
    loop_guard();   // whether its loops ran in full (gpu/loop_guard.py)
}
