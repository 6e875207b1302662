// Importance sampling of the environment from a tabulated equirectangular luminance map
// (built by reference.py: env_radiance averaged per texel on the GPU, CDFs in float64).
// Texel (i, j) covers u in [i, i+1)/W, v in [j, j+1)/H with v = 0 at the zenith, the mapping of
// env.glsl's file environments. A texel is picked with probability P_ij and a point uniformly
// inside it, so the density per solid angle is P_ij W H / (2 pi^2 sin(theta)).
uniform sampler2D u_env_marginal_cdf;      // (H + 1) x 1: cumulative row probabilities
uniform sampler2D u_env_conditional_cdf;   // (W + 1) x H: cumulative texel probabilities per row
uniform sampler2D u_env_texel_probability; // W x H: P_ij
uniform ivec2 u_env_map_size;              // (W, H)
uniform int u_env_sampling;                // 0 when the environment has no radiance to sample

vec3 equirect_direction(vec2 uv) {
    float theta = PI * uv.y, phi = 2.0 * PI * (uv.x - 0.5);
    float s = sin(theta);
    return vec3(s * sin(phi), cos(theta), -s * cos(phi));
}

vec2 equirect_uv(vec3 d) {
    return vec2(atan(d.x, -d.z) * (0.5 * INV_PI) + 0.5, acos(clamp(d.y, -1.0, 1.0)) * INV_PI);
}

// Largest k in [0, n - 1] with cdf[k] <= u, cdf stored along x of row `row` (cdf[0] = 0).
int cdf_search(sampler2D cdf, int row, int n, float u) {
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) >> 1;
        if (texelFetch(cdf, ivec2(mid, row), 0).r <= u) lo = mid; else hi = mid - 1;
    }
    return lo;
}

float env_texel_pdf(ivec2 texel, float sin_theta) {
    float p = texelFetch(u_env_texel_probability, texel, 0).r;
    return p * float(u_env_map_size.x * u_env_map_size.y) / (2.0 * PI * PI * max(sin_theta, 1e-7));
}

vec3 sample_environment(vec2 u, out float pdf) {
    int w = u_env_map_size.x, h = u_env_map_size.y;
    int j = cdf_search(u_env_marginal_cdf, 0, h, u.y);
    float c0 = texelFetch(u_env_marginal_cdf, ivec2(j, 0), 0).r;
    float c1 = texelFetch(u_env_marginal_cdf, ivec2(j + 1, 0), 0).r;
    float fy = saturate((u.y - c0) / max(c1 - c0, 1e-30));
    int i = cdf_search(u_env_conditional_cdf, j, w, u.x);
    float d0 = texelFetch(u_env_conditional_cdf, ivec2(i, j), 0).r;
    float d1 = texelFetch(u_env_conditional_cdf, ivec2(i + 1, j), 0).r;
    float fx = saturate((u.x - d0) / max(d1 - d0, 1e-30));
    vec2 uv = vec2((float(i) + fx) / float(w), (float(j) + fy) / float(h));
    vec3 d = equirect_direction(uv);
    pdf = env_texel_pdf(ivec2(i, j), sin(PI * uv.y));
    return d;
}

float environment_pdf(vec3 d) {
    vec2 uv = equirect_uv(d);
    // clamp: atan(0, 0) at the poles is undefined in GLSL
    ivec2 texel = clamp(ivec2(uv * vec2(u_env_map_size)), ivec2(0), u_env_map_size - 1);
    return env_texel_pdf(texel, sqrt(max(1.0 - d.y * d.y, 0.0)));
}
