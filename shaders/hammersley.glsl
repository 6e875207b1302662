// Low-discrepancy points for the bake integrators.

// Van der Corput radical inverse of i in [0, 1). Exact on any IEEE float32 driver for
// i < 2^24: the reversed bits have at most 24 significant bits, so float() does not round,
// and the scale is a power of two.
float radical_inverse(uint i) {
    return float(bitfieldReverse(i) >> 8u) * 5.9604644775390625e-8;   // 2^-24
}

vec2 hammersley(uint i, uint n) {
    return vec2(float(i) / float(n), radical_inverse(i));
}

// GGX half vector around +z (docs/model.md, image-based light): cos^2 theta_h = (1 - u) / (1 + (a2 - 1) u).
vec3 ggx_half_vector(vec2 u, float alpha) {
    float a2 = alpha * alpha;
    float cos2 = (1.0 - u.x) / (1.0 + (a2 - 1.0) * u.x);
    float cos_t = sqrt(cos2), sin_t = sqrt(max(1.0 - cos2, 0.0));
    float phi = 2.0 * PI * u.y;
    return vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t);
}

// The same half vector given t = sqrt(1 - u) (u as above) and phi, in a form whose rounding
// does not depend on the driver: with q = t^2 + a2 (1 - t^2) (a sum of two non-negative
// terms, never a cancellation), cos^2 = t^2 / q and sin^2 = a2 (1 - t^2) / q each carry a
// few ulps of relative error. Taking sin^2 as 1 - cos^2 instead turns an ulp of cos^2 into a
// tilt of sqrt(6e-8) = 2.4e-4 rad where the true tilt is ~alpha or 0: at alpha = 0 and
// NdotV = 1e-4 that tilt pushes l below the horizon for some samples on a driver whose
// division is not correctly rounded (x / x != 1: NVIDIA), not on another (Mesa).
vec3 ggx_half_vector_t(float t, float phi, float alpha) {
    float a2 = alpha * alpha;
    float t2 = t * t;
    float one_minus_t2 = (1.0 - t) * (1.0 + t);   // exact-ish near t = 1, where 1 - t*t is not
    float q = t2 + a2 * one_minus_t2;
    float cos_t = sqrt(t2 / q), sin_t = sqrt(a2 * one_minus_t2 / q);
    return vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t);
}
