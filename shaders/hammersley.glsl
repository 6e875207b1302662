// Low-discrepancy points for the bake integrators.
vec2 hammersley(uint i, uint n) {
    uint bits = bitfieldReverse(i);
    return vec2(float(i) / float(n), float(bits) * 2.3283064365386963e-10);
}

// GGX half vector around +z (REFERENCE.md §2): cos^2 theta_h = (1 - u) / (1 + (a2 - 1) u).
vec3 ggx_half_vector(vec2 u, float alpha) {
    float a2 = alpha * alpha;
    float cos2 = (1.0 - u.x) / (1.0 + (a2 - 1.0) * u.x);
    float cos_t = sqrt(cos2), sin_t = sqrt(max(1.0 - cos2, 0.0));
    float phi = 2.0 * PI * u.y;
    return vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t);
}
