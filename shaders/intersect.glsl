// Exact ray-scene intersection (analytic path): each sphere the ray can reach in the slab
// |z| <= R is tested in closed form; cost grows with the cells the ray crosses, not the grid.
#define MAX_CELLS_PER_AXIS 8

#include "ray_sphere.glsl"

Hit intersect_scene(vec3 ro, vec3 rd, vec2 footprint) {
    Hit hit = NO_HIT;
    float t_best = 1e30;
    // Interval where the ray is inside the slab of sphere centres |z| <= R.
    float t0 = 0.0, t1 = 1e30;
    if (abs(rd.z) > 1e-8) {
        float ta = (-u_radius - ro.z) / rd.z, tb = (u_radius - ro.z) / rd.z;
        t0 = max(0.0, min(ta, tb));
        t1 = max(ta, tb);
    } else if (abs(ro.z) > u_radius) {
        t1 = -1.0;
    }
    if (t1 > t0) {
        // Cells spanned by the ray inside the slab, widened by one sphere radius.
        float t_end = min(t1, t0 + 1e4);
        vec3 pa = ro + rd * t0, pb = ro + rd * t_end;
        vec3 lo = min(pa, pb) - u_radius, hi = max(pa, pb) + u_radius;
        ivec2 ca = nearest_cell(vec3(lo.x, hi.y, 0.0));
        ivec2 cb = nearest_cell(vec3(hi.x, lo.y, 0.0));
        ivec2 n = min(cb - ca + 1, ivec2(MAX_CELLS_PER_AXIS));
        for (int j = 0; j < MAX_CELLS_PER_AXIS; ++j) {
            if (j >= n.y) break;
            for (int i = 0; i < MAX_CELLS_PER_AXIS; ++i) {
                if (i >= n.x) break;
                ivec2 cell = ca + ivec2(i, j);
                float t = ray_sphere(ro, rd, cell_center(cell), u_radius);
                if (t > 0.0 && t < t_best) { t_best = t; hit.cell = cell; }
            }
        }
        if (t_best < 1e30) {
            hit.t = t_best;
            hit.normal = normalize(ro + rd * t_best - cell_center(hit.cell));
        }
    }
#if HAS_GROUND
    if (rd.y < 0.0) {
        float tg = (u_ground_y - ro.y) / rd.y;
        if (tg > 0.0 && tg < t_best) hit = Hit(tg, vec3(0.0, 1.0, 0.0), ivec2(-1));
    }
#endif
    return hit;
}
