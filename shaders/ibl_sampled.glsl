// The `sampled` image-based lighting of the high preset: the specular lobe integrated per
// pixel with IBL_PIXEL_SAMPLES GGX visible-normal samples (Heitz 2018), each read from the
// GGX-prefiltered map at the level whose kernel covers the sample's solid angle (filtered
// importance sampling, Krivanek & Colbert 2008, with the prefiltered levels as the filter).
// Ratio estimators keep the split sum's structure:
//   specular = f0 A <L>_A + B <L>_B,  <L>_A = sum w_A L / sum w_A,  w_A = (1 - Fc) f cos / pdf,
// with A, B from the DFG LUT. Under a uniform environment every <L> is that radiance, so the
// furnace is exactly the split sum's; as the count grows each <L> tends to the BRDF-weighted
// mean of L and the filter to a point (level 0 is the environment), so the result tends to
// the exact integral. The diffuse reads the r = 1 level: the V = N prefilter kernel of
// alpha = 1 is the normalised cosine lobe, so that level holds E(n) / pi at its texels (the
// plan keeps it at 8 x 8 or more for this path, so bilinear reconstruction stays < 1 %).
#include "hammersley.glsl"
#include "sampling.glsl"

// The prefiltered lod whose GGX kernel (V = N, peak pdf 1 / (4 pi alpha^2)) spans the solid
// angle `omega`: alpha_f = sqrt(omega / 4 pi), at x = sqrt(alpha_f) (levels - 1) on the
// chain's linear roughness scale. Between levels k and k + 1 the lookup blends two kernels;
// the blend weight is chosen so that the blend's variance (~ alpha^2, alpha_k = (k / L)^2)
// equals alpha_f^2, not linearly in x: a linear blend puts x - k of a kernel up to 10x too
// wide into small filters (+0.9 % bias on r = 0.25 metals). A wider filter (2x, 4x omega)
// measured worse: the GGX kernel's tails over-blur a sharp source.
float filtered_lod(float omega) {
    float alpha_f = sqrt(max(omega, 0.0) * (0.25 * INV_PI));
    float x = min(sqrt(alpha_f), 1.0) * u_prefiltered_lods;
    float k = min(floor(x), u_prefiltered_lods - 1.0);
    float x4 = sq(sq(x)), k4 = sq(sq(k)), k14 = sq(sq(k + 1.0));
    return k + saturate((x4 - k4) / (k14 - k4));
}

// The environment along l as a sample of the sampled path reads it: the prefiltered map at lod,
// through the stage's parallax where the stage has a probe.
vec3 sampled_radiance(vec3 l, float lod) {
#if STAGE_PROBE
    return textureLod(u_prefiltered, stage_parallax(l), lod).rgb;
#else
    return textureLod(u_prefiltered, l, lod).rgb;
#endif
}

struct SampledSpecular { vec3 mean_a; vec3 mean_b; };

SampledSpecular sampled_specular(vec3 n, vec3 v, float n_dot_v, float alpha) {
    vec3 t, b;
    basis(n, t, b);
    vec3 v_local = vec3(dot(v, t), dot(v, b), n_dot_v);
    // Narrow lobes converge with fewer samples (measured: r = 0.25 metals at 0.8 % with 128,
    // r = 0 exact with any): the count falls linearly below r = 0.5, to an eighth at most.
    uint count = uint(ceil(float(IBL_PIXEL_SAMPLES) * clamp(2.0 * sqrt(alpha), 0.125, 1.0)));
    float a2 = alpha * alpha;
    float lambda_denominator = n_dot_v + sqrt(a2 + (1.0 - a2) * n_dot_v * n_dot_v);
    vec3 sum_a = vec3(0.0), sum_b = vec3(0.0);
    float w_a = 0.0, w_b = 0.0;
    for (uint i = 0u; i < count; ++i) {
        // l = reflect(-v, h), h from the visible normals; pdf(l) = D / (2 lambda_denominator),
        // so f_spec cos / pdf = Vis NdotL 2 lambda_denominator (D cancels).
        vec3 h_local = sample_ggx_vndf(v_local, alpha, hammersley(i, count));
        float v_dot_h = dot(v_local, h_local);
        vec3 l_local = 2.0 * v_dot_h * h_local - v_local;
        if (l_local.z <= 0.0) continue;
        vec3 l = l_local.x * t + l_local.y * b + l_local.z * n;
        float pdf = d_ggx(h_local.z, alpha) / (2.0 * lambda_denominator);
        float weight = visibility_ibl(l_local.z, n_dot_v, alpha) * l_local.z * 2.0 * lambda_denominator;
        vec3 radiance = sampled_radiance(l, filtered_lod(1.0 / (float(count) * pdf)));
        float fc = pow5_one_minus(v_dot_h);
        sum_a += radiance * (weight * (1.0 - fc));
        sum_b += radiance * (weight * fc);
        w_a += weight * (1.0 - fc);
        w_b += weight * fc;
    }
    return SampledSpecular(sum_a / max(w_a, 1e-20), sum_b / max(w_b, 1e-20));
}
