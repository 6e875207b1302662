// The exact cosine-weighted occlusion (form factor) of a sphere seen from a point with normal
// n (Lagarde & de Rousiers 2014; docs/model.md, geometry): used by the analytic AO and by the cells
// stage's sphere-to-floor bounce; and the specular occlusion of a lobe by a sphere.
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

// Solid angle shared by two cones of half-angles a and b whose axes are g apart (the
// intersection of two spherical caps; Tovchigrechko & Vakser 2001, checked against Monte Carlo).
float cap_overlap(float a, float b, float g) {
    if (g >= a + b) return 0.0;
    if (g <= abs(a - b)) return 2.0 * PI * (1.0 - cos(min(a, b)));
    float ca = cos(a), cb = cos(b), cg = cos(g), sa = sin(a), sb = sin(b), sg = sin(g);
    float x = acos(clamp((cg - ca * cb) / (sa * sb), -1.0, 1.0));
    float y = acos(clamp((cb - cg * ca) / (sg * sa), -1.0, 1.0));
    float z = acos(clamp((ca - cg * cb) / (sg * sb), -1.0, 1.0));
    return max(2.0 * (PI - x - y * ca - z * cb), 0.0);
}

// The share of a specular lobe around r that a sphere (centre direction c_dir, angular radius
// sphere_half) hides: the lobe taken as the cone of the same solid angle as its V = N kernel,
// 4 pi alpha^2 (the measure ibl_sampled.glsl's filter uses), up to the hemisphere.
float specular_occlusion(vec3 r, vec3 c_dir, float sphere_half, float alpha) {
    float cos_lobe = max(1.0 - 2.0 * alpha * alpha, 0.0);
    float g = acos(clamp(dot(r, c_dir), -1.0, 1.0));
    return saturate(cap_overlap(acos(cos_lobe), sphere_half, g) / (2.0 * PI * (1.0 - cos_lobe)));
}
