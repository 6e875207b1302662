// The exact cosine-weighted occlusion (form factor) of a sphere seen from a point with normal
// n (Lagarde & de Rousiers 2014, REFERENCE.md §5): used by the analytic AO and by the cells
// stage's sphere-to-floor bounce.
// Occlusion of a sphere at relative distance d = |c - p| / R whose centre direction makes
// cosine n_dot_c with the normal: the form factor of a sphere, exact across the horizon.
float sphere_occlusion(float n_dot_c, float d) {
    float sin_sigma2 = 1.0 / (d * d);
    if (n_dot_c * n_dot_c > sin_sigma2) return sin_sigma2 * max(n_dot_c, 0.0);
    float sin_theta = sqrt(max(1.0 - n_dot_c * n_dot_c, 1e-12));
    float x = sqrt(max(1.0 / sin_sigma2 - 1.0, 1e-12));
    float y = clamp(-x * n_dot_c / sin_theta, -1.0, 1.0);
    float s = sin_theta * sqrt(1.0 - y * y);
    return max((n_dot_c * acos(y) - x * s) * sin_sigma2 + atan(s / x), 0.0) * INV_PI;
}
