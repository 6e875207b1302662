// The chart scene. STAGE shared: a rows x cols grid of equal spheres in the z = 0 plane, row 0
// on top, and an optional ground plane under the bottom row. STAGE cells: one sphere at the
// origin on its own floor, shown once per cell (below).
#if STAGE == cells
#include "cell_grid.glsl"
#else
uniform ivec2 u_grid;          // (cols, rows)
#endif
uniform float u_radius;        // sphere radius
uniform float u_spacing;       // centre-to-centre distance
uniform float u_ground_y;      // height of the ground plane

#if STAGE_PROBE
// The stage probe (stage_probe_main.glsl) sees the stage from the sphere's centre (cells) or
// the grid's centre (shared); a ray from a surface point that meets the floor meets it
// elsewhere. Reading the probe towards that floor point instead corrects the parallax (exact
// for the floor's own position).
vec3 g_shading_point = vec3(0.0);   // set by shade_point

vec3 stage_parallax_from(vec3 point, vec3 dir) {
    if (dir.y >= 0.0) return dir;   // the environment, at infinity
    vec3 q = point + dir * ((u_ground_y - point.y) / dir.y);
    return normalize(q);
}

vec3 stage_parallax(vec3 dir) { return stage_parallax_from(g_shading_point, dir); }

// How much narrower a lobe about dir looks from the probe's origin than from the shading
// point, where dir meets the floor: the floor patch it covers is nearer the point.
float stage_parallax_narrowing(vec3 dir, float alpha) {
    if (dir.y >= 0.0) return 1.0;
    float t = (u_ground_y - g_shading_point.y) / dir.y;
    vec3 q = g_shading_point + dir * t;
    float narrowing = clamp(t / max(length(q), 1e-6), 0.0, 1.0);
    return mix(1.0, narrowing, saturate(-dir.y / (2.0 * alpha + 1e-4)));
}
#endif

#if STAGE == cells
// The cells stage: every cell is one scene seen by one camera, a sphere at the origin resting
// on its own floor; g_cell is the cell the current pixel shows (it picks the material).
ivec2 g_cell = ivec2(0);

vec3 cell_center(ivec2 cell) { return vec3(0.0); }

// Who looks at the floor point q from the sphere (the stage probe, the bounce cache): mostly
// the sphere's lower half, whose normals turn the camera's level rays steeply down onto the
// floor below them. So the floor's
// light is taken towards the sphere's point above q (beyond its footprint the equator point on
// q's side), not towards the centre, which sees q at a grazing angle: a glossy floor's gloss
// depends on that angle (a dark r 0.34 floor under a uniform sky: the lower half of an r 0.18
// metal 28 % too bright seen from the centre). The choice is symmetric about the vertical, as
// the light orbit's turned probe needs (turn_probe_main.glsl).
vec3 floor_viewer(vec3 q) {
    float r2 = dot(q.xz, q.xz), radius2 = u_radius * u_radius;
    if (r2 < radius2) return vec3(q.x, -sqrt(radius2 - r2), q.z);
    return vec3(q.x, 0.0, q.z) * (u_radius * inversesqrt(r2));
}

ivec2 nearest_cell(vec3 p) { return g_cell; }

#if SCENE_SDF == all_spheres
// The seed002 preset's union over every sphere of the chart, laid out here so far apart on the
// floor that no cell's camera sees another: the same picture, at the seed's O(rows x cols) cost.
#define SEED_LAYOUT_SPACING 1e3
#endif

float sdf_spheres(vec3 p, out ivec2 cell) {
    cell = g_cell;
#if SCENE_SDF == all_spheres
    float d = 1e30;
    for (int j = 0; j < u_grid.y; ++j)
        for (int i = 0; i < u_grid.x; ++i)
            d = min(d, length(p - vec3(float(i - g_cell.x), 0.0, float(j - g_cell.y)) * SEED_LAYOUT_SPACING * u_radius) - u_radius);
    return d;
#else
    return length(p) - u_radius;
#endif
}

// The cell a pixel (GL coordinates) shows, and the pixel moved into that cell's own frame;
// cells are whole pixels wide, so every cell computes exactly the same rays.

vec2 cell_pixel(vec2 pixel, out ivec2 cell) {
    ivec2 index;
    cell = grid_cell(pixel, index);
    return pixel - vec2(u_grid_origin + index * u_cell_size);
}
#else
vec3 cell_center(ivec2 cell) {  // cell = (col, row)
    vec2 half_extent = 0.5 * vec2(u_grid - 1) * u_spacing;
    return vec3(float(cell.x) * u_spacing - half_extent.x, half_extent.y - float(cell.y) * u_spacing, 0.0);
}

// Nearest grid cell to p. With equal radii the nearest centre is the nearest surface, so the
// union SDF needs one sphere per evaluation, whatever the number of spheres.
ivec2 nearest_cell(vec3 p) {
    vec2 half_extent = 0.5 * vec2(u_grid - 1) * u_spacing;
    vec2 f = vec2(p.x + half_extent.x, half_extent.y - p.y) / u_spacing;
    return clamp(ivec2(floor(f + 0.5)), ivec2(0), u_grid - 1);
}

// Signed distance to the sphere union; cell receives the nearest sphere.
float sdf_spheres(vec3 p, out ivec2 cell) {
#if SCENE_SDF == all_spheres
    // The seed002 preset's union: every sphere, every evaluation (O(rows x cols)).
    float d = 1e30;
    for (int j = 0; j < u_grid.y; ++j)
        for (int i = 0; i < u_grid.x; ++i) {
            float di = length(p - cell_center(ivec2(i, j))) - u_radius;
            if (di < d) { d = di; cell = ivec2(i, j); }
        }
    return d;
#else
    cell = nearest_cell(p);
    return length(p - cell_center(cell)) - u_radius;
#endif
}

#endif

float sdf_spheres(vec3 p) { ivec2 c; return sdf_spheres(p, c); }

#if HAS_GROUND
float sdf_ground(vec3 p) { return p.y - u_ground_y; }
#endif

float sdf_scene(vec3 p) {
    float d = sdf_spheres(p);
#if HAS_GROUND
    d = min(d, sdf_ground(p));
#endif
    return d;
}
