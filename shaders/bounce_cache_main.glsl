#include "common.glsl"
#include "loop_guard.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "camera.glsl"
#include "surface_shading.glsl"
#include "stage_bounce.glsl"

// One draw of the cells stage's bounce cache (bounce_cache.glsl): per cell, the radiance its
// floor sends up of the light its sphere bounces onto it (diffuse, and its gloss's image of
// the sphere), the sphere shaded with the last draw's cache bound (all zero before the first).
// Texel (i, j) of a cell's tile is the floor point bounce_cache_point gives; the floor there is
// seen from the sphere's point above it (scene.glsl floor_viewer, as the stage probe sees it),
// and its texel about a texel wide (the sphere's texture level of detail). A polished white
// metal on a dark glossy floor under a uniform sky: its lower half -14 % without the gloss's
// image, -5 % with it (default, against the path tracer at 1024 spp).
layout(location = 0) out vec4 out_bounce;

// The cache's texels average the floor's gloss over their own width, and each draw shades the
// sphere once a sample: two samples do. The default scene's bench frame at 128², default /
// high: 27 / 1334 ms without the gloss, 34 / 2566 ms with every sample (4 / 16), 30 / 1764 ms
// with two; a mirror on a dark r 0.51 floor, its lower half: -10.9 / -1.6 / -3.9 %.
#define CACHE_SPECULAR_SAMPLES min(BOUNCE_SPECULAR_SAMPLES, 2)

void bounce_cache_texel() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    g_cell = texel / u_bounce_cache_tile;   // (col, row from the top), as the bounce prepass's
    vec3 q = bounce_cache_point(vec2(texel - g_cell * u_bounce_cache_tile));
    float spacing = 2.0 * u_radius / float(u_bounce_cache_tile);
    out_bounce = vec4(sphere_bounce_toward(q, normalize(floor_viewer(q) - q), g_cell, spacing, CACHE_SPECULAR_SAMPLES),
                      1.0);
}

void main() {
    bounce_cache_texel();
    loop_guard();   // whether its loops ran in full (gpu/loop_guard.py)
}
