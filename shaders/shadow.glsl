// The visible fraction of a disc light (angular radius a, direction rd) from ro past one sphere
// (centre c): one minus the overlap of the light's disc with the sphere's silhouette (angular
// radius s) at angular separation g, over the disc's area — two circles, planar in angle (error
// O(a^2) for the small sun).
float disc_visibility(vec3 ro, vec3 rd, float a, vec3 c) {
    vec3 to_c = c - ro;
    float dist = length(to_c);
    float s = asin(min(u_radius / dist, 1.0));
    float g = acos(clamp(dot(to_c / dist, rd), -1.0, 1.0));
    if (g >= a + s) return 1.0;
    if (g <= s - a) return 0.0;
    if (g <= a - s) return 1.0 - sq(s / a);
    float overlap = a * a * acos(clamp((g * g + a * a - s * s) / (2.0 * g * a), -1.0, 1.0))
                  + s * s * acos(clamp((g * g + s * s - a * a) / (2.0 * g * s), -1.0, 1.0))
                  - 0.5 * sqrt(max((-g + a + s) * (g + a - s) * (g - a + s) * (g + a + s), 0.0));
    return saturate(1.0 - overlap / (PI * a * a));
}

#if STAGE == cells
#include "ray_sphere.glsl"
// The cells stage: the only occluder is the cell's sphere (radius u_radius at the origin), so
// the visible fraction of a disc light is exact (disc_visibility).
float soft_shadow(vec3 ro, vec3 rd, float k) {
    return disc_visibility(ro, rd, atan(1.0 / k), vec3(0.0));
}

// A point light's visibility from p: whether the segment to it misses the sphere (exact).
float point_shadow(vec3 p, vec3 l, float dist) {
    float t = ray_sphere(p, l, vec3(0.0), u_radius);
    return t > 0.0 && t < dist ? 0.0 : 1.0;
}

// A point light's visible share from the floor point p (ro: p lifted off the floor): a point's
// exact, a sphere light's disc against the sphere's as the sun's; a light nearer than the
// sphere's near side cannot be hidden by it.
float point_light_visibility(vec3 ro, vec3 p, vec3 l, float dist, float angle) {
    return angle <= 0.0 ? point_shadow(ro, l, dist)
         : dist > length(p) - u_radius ? soft_shadow(ro, l, 1.0 / tan(angle)) : 1.0;
}
#elif SCENE_SDF == nearest_cell
// The shared stage: the spheres stand in the plane z = 0, so a ray towards a light meets only
// those near where it crosses the slab |z| <= radius (widened by the light's cone), up to
// `far`; each hides a share of the light's disc (disc_visibility) and what they let through
// multiplies, as if their silhouettes fell on the disc independently (off by h1 h2 - h12 where
// two meet: tests/test_alpha.py).
// The ground receives these shadows; a sphere's from its neighbours changed the default
// scene by nothing measurable (0.0780 -> 0.0781 mean FLIP at 256²) for 4 % more draw time.
const int MAX_SHADOW_SPHERES = 64;
uniform float u_shadow_far;

// The stretch [t0, t1] of the ray within the slab |z| <= half_width, up to far (t0 > t1: none).
vec2 slab_stretch(vec3 ro, vec3 rd, float half_width, float far) {
    if (abs(rd.z) <= 1e-6) return abs(ro.z) <= half_width ? vec2(0.0, far) : vec2(1.0, 0.0);
    float ta = (-half_width - ro.z) / rd.z, tb = (half_width - ro.z) / rd.z;
    return vec2(max(min(ta, tb), 0.0), min(max(ta, tb), far));
}

float grid_shadow(vec3 ro, vec3 rd, float a, float far) {
    float widen = tan(a);
    // The cone about the ray reaches widen * t further: the slab widened by that at its far end.
    vec2 stretch = slab_stretch(ro, rd, u_radius, far);
    if (stretch.x <= stretch.y) stretch = slab_stretch(ro, rd, u_radius + stretch.y * widen, far);
    float t0 = stretch.x, t1 = stretch.y;
    if (t1 < t0) return 1.0;
    vec3 e0 = ro + rd * t0, e1 = ro + rd * t1;
    float margin = u_radius + t1 * widen;
    vec2 half_extent = 0.5 * vec2(u_grid - 1) * u_spacing;
    vec2 lo = (vec2(min(e0.x, e1.x), -max(e0.y, e1.y)) - margin + half_extent) / u_spacing;
    vec2 hi = (vec2(max(e0.x, e1.x), -min(e0.y, e1.y)) + margin + half_extent) / u_spacing;
    ivec2 first = max(ivec2(ceil(lo)), ivec2(0));
    ivec2 last = min(ivec2(floor(hi)), u_grid - 1);
    float visible = 1.0;
    int tested = 0;
    for (int j = first.y; j <= last.y && tested < MAX_SHADOW_SPHERES; ++j)
        for (int i = first.x; i <= last.x && tested < MAX_SHADOW_SPHERES; ++i) {
            vec3 centre = cell_center(ivec2(i, j));
            visible *= 1.0 - light_ray_coverage(ivec2(i, j), centre, ro, rd, a) * (1.0 - disc_visibility(ro, rd, a, centre));
            ++tested;
        }
    return visible;
}

float soft_shadow(vec3 ro, vec3 rd, float k) {
    return grid_shadow(ro, rd, atan(1.0 / k), u_shadow_far);
}
#else
// The seed's union of every sphere: soft shadows by sphere tracing towards the key light
// (Inigo Quilez's improved technique). k = 1 / tan(angular radius) makes the penumbra match
// the light's size.
uniform int u_shadow_steps;
uniform float u_shadow_far;

float soft_shadow(vec3 ro, vec3 rd, float k) {
    float res = 1.0;
    float ph = 1e20;
    float t = 1e-3 * u_radius;
    for (int i = 0; i < u_shadow_steps; ++i) {
        float h = sdf_spheres(ro + rd * t);
        if (h < 1e-4 * u_radius) return 0.0;
        float y = h * h / (2.0 * ph);
        float d = sqrt(max(h * h - y * y, 0.0));
        res = min(res, k * d / max(1e-6, t - y));
        ph = h;
        t += h;
        if (t > u_shadow_far) break;
    }
    res = saturate(res);
    return res * res * (3.0 - 2.0 * res);
}
#endif
