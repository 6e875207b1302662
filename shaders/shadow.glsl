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
