// The sheen's microfacet terms (KHR_materials_sheen, as glTF-Sample-Viewer writes them), no
// options: read by lobes.glsl and by the DFG bake's sheen albedo.

// D_Charlie (Estevez & Kulla 2017), alpha = r^2.
float d_charlie(float n_dot_h, float alpha) {
    float inv_alpha = 1.0 / alpha;
    float sin2 = max(1.0 - n_dot_h * n_dot_h, 0.0);
    return (2.0 + inv_alpha) * pow(sin2, 0.5 * inv_alpha) * (0.5 * INV_PI);
}

// Charlie visibility's lambda: the fit of Estevez & Kulla, interpolated in (1 - alpha)^2.
float sheen_lambda_fit(float x, float alpha) {
    float t = sq(1.0 - alpha);
    float a = mix(21.5473, 25.3245, t);
    float b = mix(3.82987, 3.32435, t);
    float c = mix(0.19823, 0.16801, t);
    float d = mix(-1.97760, -1.27393, t);
    float e = mix(-4.32054, -4.85967, t);
    return a / (1.0 + b * pow(x, c)) + d * x + e;
}

float sheen_lambda(float cos_theta, float alpha) {
    return abs(cos_theta) < 0.5 ? exp(sheen_lambda_fit(cos_theta, alpha))
                                : exp(2.0 * sheen_lambda_fit(0.5, alpha) - sheen_lambda_fit(1.0 - cos_theta, alpha));
}

float v_sheen(float n_dot_l, float n_dot_v, float alpha) {
    return saturate(1.0 / ((1.0 + sheen_lambda(n_dot_v, alpha) + sheen_lambda(n_dot_l, alpha)) * (4.0 * n_dot_v * n_dot_l)));
}
