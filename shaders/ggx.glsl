// The microfacet terms of docs/model.md (the BRDF), one function each, no options.

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

// D seen through a disc light: the lobe averaged over a disc of half vectors (solid angle
// pi w^2) centred on h, the half vector of the disc's centre. In the slope space of n, GGX is
// p(s) = a^2 / (pi (|s|^2 + a^2)^2) = laplacian(log(|s|^2 + a^2)) / (4 pi), so by the
// divergence theorem its integral over a circle of radius r at distance d is a contour
// integral with a closed form, I = 1/2 - u / (2 S), u = d^2 + a^2 - r^2, S = sqrt(u^2 + 4 r^2
// a^2) (as (2 a^2 r^2) / (S (S + u)) where u > 0: no cancellation). The disc's slope image at
// d = tan(theta_h) has the area of a circle of radius r = w / cos^1.5, and D = I / (pi w^2 c),
// c the cos of the measure where the lobe's share I of itself within the disc lies: 1 at the
// normal (a mirror inside the disc's image: 1 / (pi w^2), the disc's radiance), cos(theta_h)
// far off (the lobe's own value there; w = 0 gives d_ggx). Here multiplied through by cos^4
// (finite at grazing). The stretch takes the centre's cos no lower than DISC_MIN_COS: further
// off the normal a wide disc's image is no circle (a bounce ray's 60-degree spread of the
// lights took its 1 / cos^3 to specks of 100x on mapped normals at grazing); the measure then
// keeps the far field GGX's own.
#define DISC_MIN_COS 0.5
float d_ggx_disc(vec3 n, vec3 h, float alpha, float w) {
    float n_dot_h = saturate(dot(n, h));
    vec3 n_x_h = cross(n, h);
    float sin2 = n_dot_h > 0.0 ? dot(n_x_h, n_x_h) : 1.0;
    float cos2 = n_dot_h * n_dot_h;
    float c = max(n_dot_h, DISC_MIN_COS);
    float a2 = alpha * alpha, w2 = w * w;
    float r2_cos2 = w2 * cos2 / (c * c * c);   // r^2 cos^2, r^2 = w^2 / c^3
    float u = sin2 + a2 * cos2 - r2_cos2;
    float s = sqrt(u * u + 4.0 * a2 * cos2 * r2_cos2);
    float inside = u > 0.0 ? 2.0 * a2 * cos2 * r2_cos2 / (s * (s + u)) : (s - u) / (2.0 * s);   // I
    // The measure's cos, c^3 c_m = cos^4 far off (the lobe's own value there, however c is
    // clamped), 1 where the lobe lies within the disc.
    float measure = mix(cos2 * cos2 / (c * c * c), 1.0, inside);
    return inside / (PI * max(w2 * measure, 1e-30));
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
