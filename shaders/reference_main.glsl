#include "common.glsl"
#include "loop_guard.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "camera.glsl"
#include "ggx.glsl"
#include "visibility.glsl"
#include "dfg.glsl"
#include "brdf.glsl"
#if USE_TEXTURES
#include "textures.glsl"
#endif
#include "material.glsl"
#include "env.glsl"
#include "lights.glsl"
#include "intersect.glsl"
#include "reference_intersect.glsl"
#include "rng.glsl"
#include "sampling.glsl"
#include "sampling_env.glsl"
#include "reference_path.glsl"
#if SHADOW_CATCHER && STAGE == cells
#include "catcher_fade.glsl"   // the chart's fade of a cell's catcher at its border
#endif

// Reference program: adds up to u_sample_count more paths per pixel to running sums, from the
// pixel's next sample (u_next) up to u_sample_end. A software rasterizer's loop limit
// (loop_guard.glsl) can cut a long batch short: such an invocation stores nothing, and the
// host draws the rest of the batch again with fewer samples a dispatch (integrator.py), so a
// pixel's sums take its samples in order whatever the dispatches, bit for bit. Pixel samples
// follow the R2 sequence (Roberts 2018) under a per-pixel random rotation: stratified for
// any count. Luminance moments are kept about a shift K (the pixel's first sample) so the
// variance does not cancel away in float32.
//
// Pixel footprint: pixel p (lower-left corner, GL pixel coordinates; under STAGE == cells
// first moved into its cell's frame by cell_pixel, as chart_main does) integrates the unit
// square [p, p + 1)^2 with a box filter: the offsets fract(rotation + s * R2) cover [0, 1)^2.
// The chart's spp > 1 average uses a rank-1 lattice centred in the same square (chart_main.glsl
// sample_offset), so both estimate the same pixel integral; the AOVs of both are the pixel
// centre p + 0.5's. The random numbers are keyed
// by the image pixel, so the cells of the cells stage get independent noise.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform image2D u_sum;       // rgb: sum of radiance, a: sum of coverage
layout(rgba32f, binding = 1) uniform image2D u_moments;   // sum (Y-K), sum (Y-K)^2, K, non-finite samples
#if SHADOW_CATCHER
layout(rgba32f, binding = 2) uniform image2D u_catcher;   // over floor-first paths: sum L, sum L_open, count (faded)
#endif
uniform ivec2 u_tile_origin;   // pixel offset of this dispatch (GL convention, y up)
uniform ivec2 u_tile_size;
layout(r32ui, binding = 3) uniform uimage2D u_next;     // the pixel's next sample
uniform int u_sample_end;     // this batch's end
uniform int u_sample_count;   // the most samples a pixel takes in this dispatch
uniform uint u_seed;

const uvec2 R2_STEP = uvec2(3242174889u, 2447445413u);   // (0.7548776662, 0.5698402909) * 2^32

void main() {
    ivec2 local_id = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(local_id, u_tile_size))) return;
    ivec2 pixel = u_tile_origin + local_id;
    int first = int(imageLoad(u_next, pixel).x);
    int last = min(first + u_sample_count, u_sample_end);
    if (first >= last) return;   // this batch's samples are in
    Rng pixel_rng = rng_init(uvec2(pixel), 0xffffffffu, u_seed);
    uvec2 rotation = rng_next_bits(pixel_rng).xy;
    vec4 sum = imageLoad(u_sum, pixel);
    vec4 moments = imageLoad(u_moments, pixel);
#if SHADOW_CATCHER
    vec4 catcher = imageLoad(u_catcher, pixel);
#endif
    vec2 base = vec2(pixel);
#if STAGE == cells
    base = cell_pixel(base, g_cell);   // the camera then sees this cell's own scene
#endif
    for (int k = first; k < last; ++k) {
        uint s = uint(k);
        Rng rng = rng_init(uvec2(pixel), s, u_seed);
        vec2 offset = vec2((rotation + s * R2_STEP) >> 8u) * (1.0 / 16777216.0);
        vec2 ndc = 2.0 * (base + offset) / u_resolution - 1.0;
        vec3 rd;
        vec3 ro = camera_ray(ndc, rd);
#if SHADOW_CATCHER
        g_catcher = vec2(-1.0);
#endif
        vec4 c = trace_path(ro, rd, rng);
#if SHADOW_CATCHER
        if (g_catcher.x >= 0.0 && !any(isnan(g_catcher)) && !any(isinf(g_catcher))) {
#if STAGE == cells
            catcher += vec4(g_catcher, catcher_fade(base + offset), 0.0);
#else
            catcher += vec4(g_catcher, 1.0, 0.0);
#endif
        }
#endif
        if (any(isnan(c)) || any(isinf(c))) {   // counted and reported, never silently kept
            moments.w += 1.0;
            c = vec4(0.0);
        }
        float y = luminance(c.rgb);
        if (s == 0u) moments.z = y;
        float d = y - moments.z;
        sum += c;
        moments.xy += vec2(d, d * d);
    }
    if (loops_cut()) return;   // counted: the host draws these samples again
    imageStore(u_sum, pixel, sum);
    imageStore(u_moments, pixel, moments);
#if SHADOW_CATCHER
    imageStore(u_catcher, pixel, catcher);
#endif
    imageStore(u_next, pixel, uvec4(uint(last)));
}
