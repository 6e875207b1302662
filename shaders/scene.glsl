// The chart scene: an rows x cols grid of equal spheres in the z = 0 plane, row 0 on top,
// and an optional ground plane under the bottom row.
uniform ivec2 u_grid;          // (cols, rows)
uniform float u_radius;        // sphere radius
uniform float u_spacing;       // centre-to-centre distance
uniform float u_ground_y;      // height of the ground plane

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
    // Shared seed 002's union: every sphere, every evaluation (O(rows x cols)).
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
