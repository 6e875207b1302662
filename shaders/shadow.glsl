#if STAGE == cells
#include "ray_sphere.glsl"
// The cells stage: the only occluder is the cell's sphere (radius u_radius at the origin), so
// the visible fraction of a disc light is exact: one minus the overlap of the light's disc
// (angular radius a) with the sphere's silhouette (angular radius s) at angular separation g,
// over the disc's area — two circles, planar in angle (error O(a^2) for the small sun).
float soft_shadow(vec3 ro, vec3 rd, float k) {
    float a = atan(1.0 / k);
    vec3 to_c = -ro;
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

// A point light's visibility from p: whether the segment to it misses the sphere (exact).
float point_shadow(vec3 p, vec3 l, float dist) {
    float t = ray_sphere(p, l, vec3(0.0), u_radius);
    return t > 0.0 && t < dist ? 0.0 : 1.0;
}
#else
// Soft shadows by sphere tracing towards the key light (Inigo Quilez's improved technique).
// k = 1 / tan(angular radius) makes the penumbra match the light's size.
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
