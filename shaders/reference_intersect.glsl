// Exact closest-hit tracing for the reference renderer, for rays that start anywhere (camera,
// surface points, shadow rays). A 2-D DDA walks the grid cells the ray crosses inside the slab
// |z| <= R, in order of distance, and tests the spheres that reach into each cell; it stops
// once the next cell starts beyond the best hit. Exact for any grid size and spacing.
// Under STAGE == cells the scene is one sphere on its floor (below).
// `skip` names the surface the ray leaves: spheres and the plane are convex, so a ray leaving
// one never meets it again and no offset epsilon is needed. SKIP_NONE skips nothing;
// ivec2(-1) (the ground's cell) skips the ground.
uniform int u_cell_reach;   // k: a sphere reaches into cells up to k away (0 when spacing >= 2R)
#define SKIP_NONE ivec2(-2)
#if SHADOW_CATCHER
bool g_open_floor = false;   // trace as if no sphere stood on the floor (the catcher's open floor)
#endif
#define MAX_DDA_STEPS 300   // > 2 * (MAX_GRID + 2 k) + 2 for every reach the Python side allows

// The ground plane, where the ray meets it before t_best (and does not leave it).
void trace_ground(vec3 ro, vec3 rd, ivec2 skip, inout Hit hit, inout float t_best) {
#if HAS_GROUND
    if (rd.y < 0.0 && skip != ivec2(-1)) {
        float tg = (u_ground_y - ro.y) / rd.y;
        if (tg > 0.0 && tg < t_best) {
            t_best = tg;
            hit = Hit(tg, vec3(0.0, 1.0, 0.0), ivec2(-1));
        }
    }
#endif
}

#if STAGE == cells
// The cells stage: each pixel's cell (g_cell, set from the pixel by cell_pixel) is one scene,
// a sphere of radius R at the origin resting on its own floor y = -R, with the environment at
// infinity; no other cell is in it. Every ray of the pixel's paths (camera, bounce, shadow)
// sees exactly that scene, so occlusion, shadows and interreflection between the sphere and
// its floor follow, and every cell computes the same light transport.
Hit trace_scene(vec3 ro, vec3 rd, float t_max, ivec2 skip) {
    Hit hit = NO_HIT;
    float t_best = t_max;
    trace_ground(ro, rd, skip, hit, t_best);
#if SHADOW_CATCHER
    if (g_open_floor) return hit;
#endif
    if (skip != g_cell) {   // a ray leaving the (convex) sphere never meets it again
        float t = ray_sphere(ro, rd, vec3(0.0), u_radius);
        if (t > 0.0 && t < t_best)
            hit = Hit(t, normalize(ro + rd * t), g_cell);
    }
    return hit;
}
#else
// Continuous cell coordinates: cell (col, row) covers [col, col + 1) x [row, row + 1).
vec2 grid_coordinates(vec3 p) {
    vec2 half_extent = 0.5 * vec2(u_grid - 1) * u_spacing;
    return vec2(p.x + half_extent.x, half_extent.y - p.y) / u_spacing + 0.5;
}

Hit trace_scene(vec3 ro, vec3 rd, float t_max, ivec2 skip) {
    Hit hit = NO_HIT;
    float t_best = t_max;
    trace_ground(ro, rd, skip, hit, t_best);
#if SHADOW_CATCHER
    if (g_open_floor) return hit;
#endif
    // Interval inside the slab of the spheres, |z| <= R.
    float t0 = 0.0, t1 = t_best;
    if (abs(rd.z) > 0.0) {
        float ta = (-u_radius - ro.z) / rd.z, tb = (u_radius - ro.z) / rd.z;
        t0 = max(t0, min(ta, tb));
        t1 = min(t1, max(ta, tb));
    } else if (abs(ro.z) > u_radius) {
        return hit;
    }
    // ... and inside the cells whose neighbourhood holds a sphere.
    int k = u_cell_reach;
    vec2 g0 = grid_coordinates(ro);
    vec2 gd = vec2(rd.x, -rd.y) / u_spacing;
    vec2 lo = vec2(-k), hi = vec2(u_grid + k);
    for (int a = 0; a < 2; ++a) {
        if (gd[a] != 0.0) {
            float ta = (lo[a] - g0[a]) / gd[a], tb = (hi[a] - g0[a]) / gd[a];
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        } else if (g0[a] < lo[a] || g0[a] >= hi[a]) {
            return hit;
        }
    }
    if (!(t0 < t1)) return hit;

    vec2 g = g0 + gd * t0;
    ivec2 cell = clamp(ivec2(floor(g)), ivec2(-k), u_grid - 1 + k);
    ivec2 step_dir = ivec2(sign(gd));
    vec2 t_delta, t_next;
    for (int a = 0; a < 2; ++a) {
        if (gd[a] != 0.0) {
            t_delta[a] = 1.0 / abs(gd[a]);
            t_next[a] = (float(cell[a] + (gd[a] > 0.0 ? 1 : 0)) - g0[a]) / gd[a];
        } else {
            t_delta[a] = 1e30;
            t_next[a] = 1e30;
        }
    }
    float t_enter = t0;
    for (int i = 0; i < MAX_DDA_STEPS; ++i) {
        if (t_enter >= t_best || t_enter > t1) break;
        if (any(lessThan(cell, ivec2(-k))) || any(greaterThan(cell, u_grid - 1 + k))) break;
        for (int dj = -k; dj <= k; ++dj) {
            for (int di = -k; di <= k; ++di) {
                ivec2 c = cell + ivec2(di, dj);
                if (any(lessThan(c, ivec2(0))) || any(greaterThanEqual(c, u_grid)) || c == skip) continue;
                float t = ray_sphere(ro, rd, cell_center(c), u_radius);
                if (t > 0.0 && t < t_best) {
                    t_best = t;
                    hit.t = t;
                    hit.cell = c;
                }
            }
        }
        if (t_next.x < t_next.y) {
            t_enter = t_next.x;
            t_next.x += t_delta.x;
            cell.x += step_dir.x;
        } else {
            t_enter = t_next.y;
            t_next.y += t_delta.y;
            cell.y += step_dir.y;
        }
    }
    if (hit.t > 0.0 && hit.cell.x >= 0)
        hit.normal = normalize(ro + rd * hit.t - cell_center(hit.cell));
    return hit;
}

#endif
