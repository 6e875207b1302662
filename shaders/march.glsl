// Sphere tracing of the SDF (marched path). The hit threshold scales with the pixel footprint
// (footprint.x + footprint.y * t: orthographic + perspective) so that far spheres are not over-refined and near ones not under-refined.
uniform int u_march_steps;
uniform float u_march_far;
uniform float u_hit_scale;     // hit when d < u_hit_scale * pixel footprint + u_hit_epsilon
uniform float u_hit_epsilon;

Hit intersect_scene(vec3 ro, vec3 rd, vec2 footprint) {
    float t = 0.0;
    for (int i = 0; i < u_march_steps; ++i) {
        vec3 p = ro + rd * t;
        float d = sdf_scene(p);
        float eps = u_hit_scale * (footprint.x + footprint.y * t) + u_hit_epsilon;
        if (d < eps) {
            Hit hit;
            hit.t = t;
            ivec2 cell;
            float ds = sdf_spheres(p, cell);
#if HAS_GROUND
            if (sdf_ground(p) < ds) return Hit(t, vec3(0.0, 1.0, 0.0), ivec2(-1));
#endif
            hit.cell = cell;
            // The epsilon floor follows the scene's scale and |p|: a fixed 1e-5 fell below fp32
            // resolution for 1000-unit spheres and normalize(0) gave NaN (`sdfpbr stress`).
            hit.normal = sdf_normal(p, max(footprint.x + footprint.y * t, max(1e-4 * u_radius, 1e-6 * length(p))));
            return hit;
        }
        t += d;
        if (t > u_march_far) break;
    }
    return NO_HIT;
}
