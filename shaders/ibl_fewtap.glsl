// The fewtap-ibl bug (and the seed002 preset): a Shadertoy-style raymarcher's environment
// lighting in our terms (docs/model.md). Specular: five weighted taps of the environment around R, spread by roughness^2, times
// an ad-hoc fit instead of the DFG integral; diffuse: the radiance along N as if the
// environment were uniform. No prefiltering, no irradiance integral, no LUT.
vec3 shade_ibl(Material m, vec3 n, vec3 v, float n_dot_v, vec3 dfg) {
    float r = m.perceptual_roughness;
    vec3 f0 = mix(vec3(DIELECTRIC_F0), m.base_color_linear, m.metallic);
    vec3 f = f0 + (max(vec3(1.0 - r), f0) - f0) * pow5_one_minus(n_dot_v);
    vec3 diffuse = (1.0 - f) * (1.0 - m.metallic) * m.base_color_linear * env_radiance(n);
    vec3 r_dir = reflect(-v, n);
    vec3 t = normalize(cross(r_dir, vec3(0.0, 1.0, 0.1)));
    vec3 b = cross(r_dir, t);
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    for (int i = 0; i < 5; ++i) {
        float fi = float(i);
        float spread = r * r * 0.5 * (fi * 0.2 + 0.1);
        vec3 d = normalize(r_dir + (t * cos(fi * 1.2566) + b * sin(fi * 1.2566)) * spread);
        float w = 1.0 / (1.0 + fi * 0.5);
        sum += env_radiance(d) * w;
        weight += w;
    }
    vec3 scale = f * (1.0 - 0.5 * r) + pow5_one_minus(n_dot_v) * (1.0 - r) * 0.1;
    return diffuse + sum / weight * scale;
}
