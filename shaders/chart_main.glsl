#include "common.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "camera.glsl"
#include "surface_shading.glsl"
#include "background.glsl"
#include "loop_guard.glsl"
#if INTERSECT == analytic
#include "intersect.glsl"
#else
#include "normal.glsl"
#include "march.glsl"
#endif
#if ANALYTIC_AA
#if EDGE_PIXELS != skipped
#include "edge_coverage.glsl"
#endif
#endif
#if STAGE == cells && HAS_GROUND && USE_AO && !BOUNCE_PREPASS
#include "stage_bounce.glsl"   // the light the AO takes from the floor's sky, given back by the sphere
#endif
#if SEE_THROUGH && STAGE == cells && HAS_GROUND && USE_SHADOWS && USE_TEXTURES
#if HAS_BASE_COLOR_MAP
#include "patterned_shadow.glsl"   // a see-through sphere's shadows in its map's pattern
#endif
#endif
#if SHADOW_CATCHER && STAGE == cells
#include "catcher_fade.glsl"   // no seams between the cells' own floors
#endif

// Chart program: one fullscreen triangle per tile (CHART_SHADER fragment), or one invocation
// per pixel of the tile (compute: where a GPU runs few fragment units, session.py picks it);
// each pixel integrates its box, with SPP stratified rays or (ANALYTIC_AA) the silhouette's
// exact coverage. Outputs linear HDR radiance + coverage, and the AOVs of the pixel-centre ray.
#if CHART_SHADER == compute
layout(local_size_x = 8, local_size_y = 8) in;
vec4 out_radiance;      // stored to the images by main() below
vec4 out_normal_depth;
vec4 out_cell;
#else
layout(location = 0) out vec4 out_radiance;      // rgb radiance, a coverage
layout(location = 1) out vec4 out_normal_depth;  // world normal, distance along the ray
layout(location = 2) out vec4 out_cell;          // col, row, NdotV (-1 for background), sphere coverage
#endif
uniform vec2 u_tile_origin;                      // pixel offset of this tile in the image
uniform int u_spp;
uniform int u_sample_step;   // the samples' lattice generator, coprime with u_spp (gpu/render.py)
#if SUPERSAMPLE
// This draw's samples [first, end) of each pixel's u_spp; the draws add up (gpu/render.py: as
// many draws as a software rasterizer's loop limit needs, loop_guard.glsl).
uniform ivec2 u_sample_range;
#endif

// Sample i of u_spp in the pixel box: a rank-1 lattice whose every axis holds each of the spp
// strata once, so the samples' mean is the pixel's centre (the R2 sequence from the centre put
// the mean of 4 samples 0.12 and 0.15 px off it, shifting the image against its reference: FLIP
// 0.043 at spp 4 where spp 1 read 0.017). One sample: the centre.
vec2 sample_offset(int i) {
    return (vec2(float(i), float((i * u_sample_step) % u_spp)) + 0.5) / float(u_spp);
}

#if FLOOR_PREPASS
uniform sampler2D u_floor_prepass;   // the floor's light without its sphere's bounce (stage_floor_main.glsl)
uniform vec2 u_prepass_origin;       // the cell pixel of its texel (0, 0)
#endif
#if BOUNCE_PREPASS
uniform sampler2D u_bounce_prepass;  // each cell's sphere's light on its floor, every u_bounce_step pixels
uniform ivec2 u_bounce_tile;       // texels per cell (stage_bounce_main.glsl)
uniform float u_bounce_step;

// The bounce at a cell-frame position, interpolated between the prepass's texels in its cell's
// tile (clamped to the tile: a neighbour's sphere lights its own floor, not this one).
vec3 bounce_prepass(vec2 position) {
    vec2 at = clamp((position - u_prepass_origin - 0.5) / u_bounce_step, vec2(0.0), vec2(u_bounce_tile - 1));
    return texture(u_bounce_prepass, (vec2(g_cell * u_bounce_tile) + at + 0.5) / vec2(textureSize(u_bounce_prepass, 0))).rgb;
}
#endif

#if SPHERE_PREPASS
uniform sampler2D u_sphere_prepass;  // each slot's sphere per cell pixel, as a dielectric and as a metal
uniform sampler2D u_sphere_slots;  // each cell's slot (texel (col, row))
uniform ivec2 u_sphere_origin;     // the cell pixel of a tile's texel (0, 0) (stage_sphere_main.glsl)
uniform ivec2 u_sphere_tile;       // texels of a tile: the cell's pixels and the image's margins
uniform int u_sphere_tiles_x;
ivec2 g_prepass_texel = ivec2(0);    // the pixel being drawn, in a tile

vec3 sphere_prepass_tile(int index) {
    ivec2 tile = ivec2(index % u_sphere_tiles_x, index / u_sphere_tiles_x);
    return texelFetch(u_sphere_prepass, tile * u_sphere_tile + g_prepass_texel, 0).rgb;
}
#endif

#if GATHER_PREPASS
uniform sampler2D u_gather_prepass;  // each cell's sphere's light back from its floor (stage_gather_main.glsl)
uniform ivec2 u_gather_tile;
uniform float u_gather_step;
#endif

// What the sphere point p gets back from its floor's bounce cache where shade_point leaves it
// out: read from the gather prepass at the pixel's position, or gathered here where the sphere
// prepass stands for several cells.
vec3 sphere_gather(vec2 position, vec3 p, vec3 n_geo, vec3 v, ivec2 cell, float pixel_size) {
#if GATHER_PREPASS
    vec2 at = clamp((position - u_prepass_origin - 0.5) / u_gather_step, vec2(0.0), vec2(u_gather_tile - 1));
    return texture(u_gather_prepass, (vec2(cell * u_gather_tile) + at + 0.5) / vec2(textureSize(u_gather_prepass, 0))).rgb;
#elif BOUNCE_CACHE && SPHERE_PREPASS
    Surface s = surface_at(p, n_geo, v, cell, pixel_size, false);   // the cell's maps applied
    return bounce_gather(s.m, s.p, s.n, s.v, s.dfg, cell, BOUNCE_GATHER_SAMPLES);
#else
    return vec3(0.0);
#endif
}

// The light a sphere point sends to the camera (seen through `position`): shaded here, or
// (SPHERE_PREPASS) the cell's slot from the prepass as a dielectric and as a metal, mixed by the
// cell's metallic (the shading is linear in it). The prepass leaves the sphere's shading out of
// this program: a software rasterizer runs both sides of a branch.
vec3 sphere_radiance(vec2 position, vec3 p, vec3 n_geo, vec3 v, ivec2 cell, float pixel_size) {
#if SPHERE_PIXELS == skipped
    // The spheres' pixels are drawn over by the sphere pass (SPHERE_PIXELS only, on each
    // sphere's box): a software rasterizer would shade the sphere for every floor pixel too.
    return vec3(0.0);
#elif SPHERE_PREPASS
    int slot = int(texelFetch(u_sphere_slots, cell, 0).r);
    float metallic = cell_texel(cell, 0).a;
    vec3 dielectric = sphere_prepass_tile(2 * slot), metal = sphere_prepass_tile(2 * slot + 1);
    // The ends exactly (a NaN at one end stays out of the other).
    vec3 radiance = metallic <= 0.0 ? dielectric : metallic >= 1.0 ? metal : mix(dielectric, metal, metallic);
    return radiance + sphere_gather(position, p, n_geo, v, cell, pixel_size);
#else
    return shade_sphere(p, n_geo, v, cell, pixel_size) + sphere_gather(position, p, n_geo, v, cell, pixel_size);
#endif
}

// Radiance and coverage of what the primary ray through `position` (cell frame on the cells
// stage) found: a hit's shading, or the background.
vec4 shade_hit(vec2 position, vec3 ro, vec3 rd, Hit hit, vec2 footprint) {
#if SPHERE_PIXELS == only && !SEE_THROUGH
#if EDGE_PIXELS == skipped
    // The sphere pass keeps only the pixels whose ray meets a sphere (chart_pixel): the floor
    // and the background are the chart pass's (and an edge's outer ray the edge pass's).
    return vec4(sphere_radiance(position, ro + rd * hit.t, hit.normal, -rd, hit.cell, footprint.x + footprint.y * hit.t), 1.0);
#endif
#endif
#if FLOOR_PREPASS
    // The prepass holds what a miss sees too: the background is the same in every cell.
    vec4 prepass = hit.cell.x < 0 ? texture(u_floor_prepass, (position - u_prepass_origin) / vec2(textureSize(u_floor_prepass, 0)))
                                : vec4(0.0);
    if (hit.t < 0.0) return vec4(prepass.rgb, 0.0);
#else
    if (hit.t < 0.0) return vec4(background(rd), 0.0);
#endif
    vec3 p = ro + rd * hit.t;
    float pixel_size = footprint.x + footprint.y * hit.t;
#if FLOOR_PREPASS
    vec3 radiance = hit.cell.x < 0 ? prepass.rgb : sphere_radiance(position, p, hit.normal, -rd, hit.cell, pixel_size);
#else
    vec3 radiance = hit.cell.x < 0 ? shade_ground(p, -rd, pixel_size) : sphere_radiance(position, p, hit.normal, -rd, hit.cell, pixel_size);
#endif
#if BOUNCE_PREPASS
    if (hit.cell.x < 0) radiance += bounce_prepass(position);
#elif STAGE == cells && HAS_GROUND && USE_AO
    if (hit.cell.x < 0) radiance += sphere_bounce(p, -rd, g_cell, pixel_size);
#endif
#if SEE_THROUGH && STAGE == cells
    // The floor as its sphere leaves it (shadow, occlusion, bounce) in the share of the light
    // the sphere stops, the open floor in the rest.
    if (hit.cell.x < 0) {
        float stops = light_coverage(g_cell);
        if (stops < 1.0) radiance = mix(shade_open_ground(p, -rd, pixel_size), radiance, stops);
#if USE_SHADOWS && USE_TEXTURES
#if HAS_BASE_COLOR_MAP
        radiance -= patterned_shadow_correction(p, -rd, g_cell, stops, pixel_size);
#endif
#endif
    }
#endif
#if SHADOW_CATCHER
    if (hit.cell.x < 0) {
#if FLOOR_PREPASS
        vec4 catcher = shadow_catcher(radiance, prepass.a);
#else
        vec4 catcher = shadow_catcher(radiance, luminance(shade_open_ground(p, -rd, pixel_size)));
#endif
#if STAGE == cells
        catcher.a *= catcher_fade(position);
#endif
        return catcher;
    }
#endif
    return vec4(radiance, 1.0);
}

// Radiance along the primary ray through `position`, a = coverage. `hit` receives what the
// ray found first (for the AOVs).
vec4 trace_pixel(vec2 position, vec2 footprint, out Hit hit, out vec3 rd) {
    vec3 ro = camera_ray(2.0 * position / u_resolution - 1.0, rd);
    hit = intersect_scene(ro, rd, footprint);
// (On the chart pass, a sphere's pixels are the sphere pass's.)
#if SEE_THROUGH && SPHERE_PIXELS != skipped
    if (hit.t >= 0.0 && hit.cell.x >= 0) {
        float alpha = sphere_alpha(hit.cell, hit.normal, footprint.x + footprint.y * hit.t);
        if (alpha < 1.0) {
            // Single-sided, as glTF's default: the ray crosses the sphere unseen (a chord of
            // 2 R cos) and goes on to what lies behind it; the sphere is laid over that.
            // The search starts a few pixels past the exit (the marcher would otherwise meet the
            // sphere it leaves within its hit threshold), with the pixel footprint there.
            float t_exit = hit.t + 2.0 * u_radius * max(dot(hit.normal, -rd), 0.0);
            t_exit += 4.0 * (footprint.x + footprint.y * t_exit) + 1e-3 * u_radius;
            Hit behind = intersect_scene(ro + rd * t_exit, rd, vec2(footprint.x + footprint.y * t_exit, footprint.y));
            if (behind.t >= 0.0) behind.t += t_exit;
#if INTERSECT == march
            if (behind.t > u_march_far) behind = NO_HIT;   // as far as the camera's own rays reach
#endif
#if HAS_GROUND
            // A ray grazing the sphere's foot leaves it (t_exit) already below the floor: the
            // floor it crossed, from the camera itself. (Only there: elsewhere the search's own
            // floor, which a marcher may not reach near the horizon, as beside the sphere.)
            float t_floor = rd.y < 0.0 ? (u_ground_y - ro.y) / rd.y : -1.0;
            if (behind.t < 0.0 && t_floor > hit.t && t_floor < t_exit)
                behind = Hit(t_floor, vec3(0.0, 1.0, 0.0), ivec2(-1));
#endif
            vec4 back = shade_hit(position, ro, rd, behind, footprint);
            return alpha > 0.0 ? mix(back, shade_hit(position, ro, rd, hit, footprint), alpha) : back;
        }
    }
#endif
    return shade_hit(position, ro, rd, hit, footprint);
}

// The pixel whose centre is frag_coord in the tile (GL window coordinates).
void chart_pixel(vec2 frag_coord) {
    vec2 pixel = frag_coord - 0.5 + u_tile_origin;
#if STAGE == cells
    pixel = cell_pixel(pixel, g_cell);   // the camera then sees this cell's own scene
#endif
#if SPHERE_PREPASS
    g_prepass_texel = ivec2(pixel) - u_sphere_origin;   // whole pixels: cells are whole pixels apart
#endif
    vec2 footprint = pixel_footprint();
    Hit centre;            // the pixel-centre ray's hit, for the AOVs
    vec3 centre_rd;
    Hit other;
    vec3 other_rd;
#if ANALYTIC_AA
    // One ray per pixel, and two at the sphere's silhouette, blended by the covered share of
    // the pixel box (edge_coverage.glsl).
#if EDGE_PIXELS == skipped
    // The silhouette's pixels are drawn over by the edge pass (EDGE_PIXELS only, on a ring of
    // triangles round each silhouette: shading/silhouette.py), or without one by the sphere
    // pass. A software rasterizer runs an if's body for every pixel, so the edge's second
    // trace here would cost a whole trace.
    const bool edge = false;
    vec2 first = pixel + 0.5;
#else
    EdgeSplit split = edge_split(pixel + 0.5);
    bool edge = split.coverage > 0.0 && split.coverage < 1.0;
#if EDGE_PIXELS == only
    if (!edge) discard;   // the chart pass's pixel stands
#endif
    // Two traces, not three, where a SIMD group holds an edge (EDGE_SAMPLES 1): the first ray
    // is the centre's, or the covered part's first sample at an edge.
    vec2 first = edge ? split.inside : pixel + 0.5;
#endif
    vec4 radiance = trace_pixel(first, footprint, centre, centre_rd);
    float sphere_share = centre.t >= 0.0 && centre.cell.x >= 0 ? 1.0 : 0.0;
#if SPHERE_PIXELS == only
    if (sphere_share == 0.0) discard;   // the chart pass's pixel stands
#endif
#if SPHERE_SAMPLES > 1 && !SPHERE_PREPASS && SPHERE_PIXELS != skipped
    // A small sphere's inside pixels average n x n points of their box, as the sphere prepass's
    // do (stage_sphere_main.glsl), so both paths draw the same sphere.
    // The points whose rays meet the sphere (all but a few by the silhouette).
    if (!edge && sphere_share > 0.0) {
        vec4 sum = vec4(0.0);
        float count = 0.0;
        g_glint_share = 1.0 / float(SPHERE_SAMPLES);
        for (int j = 0; j < SPHERE_SAMPLES; ++j)
            for (int i = 0; i < SPHERE_SAMPLES; ++i) {
                vec4 c = trace_pixel(pixel + (vec2(i, j) + 0.5) / float(SPHERE_SAMPLES), footprint, other, other_rd);
                if (other.t >= 0.0 && other.cell.x >= 0) { sum += c; count += 1.0; }
            }
        if (count > 0.0) radiance = sum / count;
        g_glint_share = 1.0;
    }
#endif
#if EDGE_PIXELS != skipped
#if EDGE_SAMPLES > 1 && !SPHERE_PREPASS
    // A silhouette pixel's covered part: the mean of its samples whose rays meet the sphere
    // (as the sphere prepass's texel, stage_sphere_main.glsl); the first ray was sample 0.
    if (edge) {
        vec4 sum = radiance * sphere_share;
        float count = sphere_share;
        for (int k = 1; k < EDGE_SAMPLES; ++k) {
            vec4 c = trace_pixel(edge_sample_point(split, k), footprint, other, other_rd);
            if (other.t >= 0.0 && other.cell.x >= 0) { sum += c; count += 1.0; }
        }
        if (count > 0.0) radiance = sum / count;
    }
#endif
    if (edge) {
        radiance = mix(trace_pixel(split.outside, footprint, other, other_rd), radiance, split.coverage);
        sphere_share = split.coverage;
        vec3 ro = camera_ray(2.0 * (pixel + 0.5) / u_resolution - 1.0, centre_rd);
        centre = intersect_scene(ro, centre_rd, footprint);
    }
#endif
#elif SUPERSAMPLE
    // SPP stratified rays over the pixel box, this draw's share of their mean. The AOVs show
    // the centre ray's hit, from the first draw (the others add nothing to them).
    vec4 radiance = vec4(0.0);
    float sphere_share = 0.0;
    g_glint_share = inversesqrt(float(u_spp));
    for (int s = u_sample_range.x; s < u_sample_range.y; ++s) {
        radiance += trace_pixel(pixel + sample_offset(s), footprint, other, other_rd);
        sphere_share += other.t >= 0.0 && other.cell.x >= 0 ? 1.0 : 0.0;
    }
    vec3 ro = camera_ray(2.0 * (pixel + 0.5) / u_resolution - 1.0, centre_rd);
    centre = u_sample_range.x == 0 ? intersect_scene(ro, centre_rd, footprint) : NO_HIT;
    radiance /= float(u_spp);
    sphere_share /= float(u_spp);
#else
    // One ray through the pixel's centre (a loop only where spp > 1: llvmpipe runs a loop's
    // body once even when it runs no turn).
    vec4 radiance = trace_pixel(pixel + sample_offset(0), footprint, centre, centre_rd);
    float sphere_share = centre.t >= 0.0 && centre.cell.x >= 0 ? 1.0 : 0.0;
#endif
    out_radiance = radiance;
    out_normal_depth = centre.t < 0.0 ? vec4(0.0, 0.0, 0.0, 1.0 / 0.0) : vec4(centre.normal, centre.t);
    float n_dot_v = centre.t < 0.0 ? -1.0 : dot(centre.normal, -centre_rd);
    out_cell = centre.t < 0.0 ? vec4(-1.0, -1.0, -1.0, sphere_share) : vec4(vec2(centre.cell), n_dot_v, sphere_share);
#if SUPERSAMPLE
    if (u_sample_range.x > 0) {   // added to the first draw's AOVs: its share of the coverage only
        out_normal_depth = vec4(0.0);
        out_cell = vec4(0.0, 0.0, 0.0, sphere_share);
    }
#endif
#if HALF_RADIANCE
    // A half-float target holds at most 65504; some drivers turn larger values into Inf.
    out_radiance = min(out_radiance, vec4(65504.0));
#endif
    loop_guard();   // last: whether all the loops above ran in full
}

#if CHART_SHADER == compute
#if HALF_RADIANCE
layout(rgba16f, binding = 0) uniform image2D u_radiance_out;
#else
layout(rgba32f, binding = 0) uniform image2D u_radiance_out;
#endif
layout(rgba32f, binding = 1) uniform writeonly image2D u_normal_depth_out;
layout(rgba32f, binding = 2) uniform image2D u_cell_out;
uniform ivec2 u_tile_size;
uniform bool u_write_aovs;   // the AOV images are bound only when the AOVs are read

void main() {
    ivec2 id = ivec2(gl_GlobalInvocationID.xy);
    if (id.x >= u_tile_size.x || id.y >= u_tile_size.y) return;
    chart_pixel(vec2(id) + 0.5);
#if SUPERSAMPLE
    if (u_sample_range.x > 0) {   // a later draw of the pixel's samples: adds to what is there
        imageStore(u_radiance_out, id, imageLoad(u_radiance_out, id) + out_radiance);
        if (u_write_aovs) imageStore(u_cell_out, id, imageLoad(u_cell_out, id) + out_cell);
        return;
    }
#endif
    imageStore(u_radiance_out, id, out_radiance);
    if (u_write_aovs) {
        imageStore(u_normal_depth_out, id, out_normal_depth);
        imageStore(u_cell_out, id, out_cell);
    }
}
#else
void main() {
    chart_pixel(gl_FragCoord.xy);
}
#endif
