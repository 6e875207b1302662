// The microfacet terms of REFERENCE.md §1, one function each, no options.

float d_ggx(float n_dot_h, float alpha) {
    float a2 = alpha * alpha;
    float f = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * f * f);
}

// The same D from the vectors, for shading: 1 - NdotH^2 taken as |n x h|^2 keeps its precision
// at the peak, where NdotH rounds to 1 in fp32 and the form above errs by up to 13 % inside
// the highlight core of alpha = 0.045^2 (found by `sdfpbr stress`; Filament's D_GGX does this).
float d_ggx(vec3 n, vec3 h, float alpha) {
    float n_dot_h = saturate(dot(n, h));
    vec3 n_x_h = cross(n, h);
    float sin2 = n_dot_h > 0.0 ? dot(n_x_h, n_x_h) : 1.0;
    float k = alpha / (sin2 + sq(n_dot_h * alpha));
    return k * k * INV_PI;
}

float vis_smith_ggx_correlated(float n_dot_l, float n_dot_v, float alpha) {
    float a2 = alpha * alpha;
    float ggx_v = n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
    float ggx_l = n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2);
    return 0.5 / max(ggx_v + ggx_l, 1e-12);   // 0 only when both cosines are 0
}

float vis_schlick_ggx(float n_dot_l, float n_dot_v, float k) {
    return 0.25 / ((n_dot_l * (1.0 - k) + k) * (n_dot_v * (1.0 - k) + k));
}

vec3 fresnel_schlick(vec3 f0, float v_dot_h) {
    return f0 + (1.0 - f0) * pow5_one_minus(v_dot_h);
}
