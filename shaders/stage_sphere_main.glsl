#include "common.glsl"
#include "loop_guard.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "camera.glsl"
#include "surface_shading.glsl"
#include "intersect.glsl"
#if ANALYTIC_AA
#include "edge_coverage.glsl"
#endif

// The cells stage's sphere prepass (SPHERE_PREPASS, sdfpbr/shading/cells.py): each slot's sphere
// shaded once per cell pixel at metallic 0 (tile 2 k) and 1 (tile 2 k + 1), at the points the
// chart's own rays of that pixel meet it (the centre, or with the analytic edge the covered
// part's samples, as chart_main.glsl's chart_pixel traces), with the material of a cell of
// the slot.
layout(location = 0) out vec4 out_radiance;
uniform ivec2 u_sphere_origin;     // the cell pixel of a tile's texel (0, 0)
uniform ivec2 u_sphere_tile;       // texels of a tile: a cell's pixels and the image's margins
uniform int u_sphere_tiles_x;
uniform sampler2D u_slot_cells;    // texel k: (col, row) of a cell of slot k

// The sphere's point nearest a ray that passes it by (the sphere is at the origin).
Hit nearest_on_sphere(vec3 ro, vec3 rd) {
    vec3 n = normalize(ro + rd * max(dot(-ro, rd), 0.0));
    return Hit(dot(n * u_radius - ro, rd), n, g_cell);
}

#if ANALYTIC_AA
// One of the points a texel averages (as the chart takes them): the sphere's light along the
// ray through pixel position q, added to sum and counted where the ray meets the sphere.
void add_sphere_point(vec2 q, vec2 footprint, inout vec3 sum, inout float count) {
    vec3 d;
    vec3 o = camera_ray(2.0 * q / u_resolution - 1.0, d);
    Hit h = intersect_scene(o, d, footprint);
    if (h.t >= 0.0 && h.cell.x >= 0) {
        sum += shade_sphere(o + d * h.t, h.normal, -d, g_cell, footprint.x + footprint.y * h.t);
        count += 1.0;
    }
}
#endif

void sphere_prepass_texel() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    ivec2 tile = texel / u_sphere_tile;
    int index = tile.y * u_sphere_tiles_x + tile.x;
    vec2 pixel = vec2(texel - tile * u_sphere_tile + u_sphere_origin);   // as chart_pixel's
    g_cell = ivec2(texelFetch(u_slot_cells, ivec2(index / 2, 0), 0).rg);
    g_prepass_metallic = float(index % 2);
    out_radiance = vec4(0.0);
    vec2 footprint = pixel_footprint();
#if ANALYTIC_AA
    EdgeSplit split = edge_split(pixel + 0.5);
    bool edge = split.coverage > 0.0 && split.coverage < 1.0;
    vec2 position = edge ? split.inside : pixel + 0.5;
#else
    vec2 position = pixel + 0.5;   // the chart's one ray, its sample 0
#endif
    vec3 rd;
    vec3 ro = camera_ray(2.0 * position / u_resolution - 1.0, rd);
    Hit hit = intersect_scene(ro, rd, footprint);
    if (hit.t < 0.0 || hit.cell.x < 0) {
#if ANALYTIC_AA
        // The chart's ray of a pixel the silhouette crosses might meet the sphere where this
        // one, rounded otherwise, passes it by: shade the sphere's point nearest the ray.
        if (split.coverage <= 0.0) return;
        hit = nearest_on_sphere(ro, rd);
#else
        return;   // the same ray as the chart's: it reads no texel here
#endif
    }
#if ANALYTIC_AA   // (without it the chart takes one ray a pixel, as the prepass does below)
#if EDGE_SAMPLES > 1
    // A silhouette pixel: the mean of points spread across its covered part
    // (edge_coverage.glsl), those whose rays meet the sphere, as the chart takes them.
    if (edge) {
        vec3 sum = vec3(0.0);
        float count = 0.0;
        for (int k = 0; k < EDGE_SAMPLES; ++k)
            add_sphere_point(edge_sample_point(split, k), footprint, sum, count);
        if (count > 0.0) {
            out_radiance = vec4(sum / count, 1.0);
            return;
        }
    }
#endif
#if SPHERE_SAMPLES > 1
    // A sphere only a few pixels wide: its pixels average n x n points of their box (the box
    // the reference integrates), so a highlight smaller than a pixel is a small disc, not one
    // bright pixel or none. Edge pixels keep their covered part's samples (their coverage blends).
    // The points whose rays meet the sphere (all but a few by the silhouette), as the chart
    // takes them where it shades the sphere itself.
    if (!edge) {
        vec3 sum = vec3(0.0);
        float count = 0.0;
        g_glint_share = 1.0 / float(SPHERE_SAMPLES);
        for (int j = 0; j < SPHERE_SAMPLES; ++j)
            for (int i = 0; i < SPHERE_SAMPLES; ++i)
                add_sphere_point(pixel + (vec2(i, j) + 0.5) / float(SPHERE_SAMPLES), footprint, sum, count);
        g_glint_share = 1.0;   // (no point met the sphere: the one ray below stands for the pixel)
        if (count > 0.0) {
            out_radiance = vec4(sum / count, 1.0);
            return;
        }
    }
#endif
#endif
    vec3 p = ro + rd * hit.t;
    out_radiance = vec4(shade_sphere(p, hit.normal, -rd, g_cell, footprint.x + footprint.y * hit.t), 1.0);
}

void main() {
    sphere_prepass_texel();
    loop_guard();   // whether its loops ran in full (gpu/loop_guard.py)
}
