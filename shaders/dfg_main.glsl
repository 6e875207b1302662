#include "common.glsl"
#include "ggx.glsl"
#include "visibility.glsl"
#include "hammersley.glsl"
#if SHEEN
#include "sheen.glsl"
#endif

// The DFG LUT (docs/model.md, image-based light) by GGX importance sampling with the shading's visibility:
// texel (i, j) holds (A, B, C, E_s or 1) at NdotV = i/(size-1), perceptual roughness = j/(size-1): the
// inverse of dfg_lookup, which puts 0 and 1 on the first and last texel centres.
//
// The specular estimator is a quadrature, not a random walk, so its error is its bias, and it
// is made well conditioned on any IEEE float32 driver (docs/model.md's test vectors, measured against the
// float64 quadrature of sdfpbr.oracle.shading_model in tests/test_shading.py):
// - In the CDF variable u of D cos(theta_h) the integrand grows like 1/sqrt(1 - u) towards
//   u = 1 as NdotV -> 0 (1/NdotH, with l still above the horizon), so a rule on u errs by
//   O(1/sqrt(N)): 0.0068 at N = 4096 on llvmpipe, and the few samples nearest u = 1 carry
//   most of it. Sampling t = sqrt(1 - u) instead (u = 1 - t^2, du = 2 t dt) cancels the
//   singularity; t runs over cell midpoints (a midpoint rule, O(1/N^2) on smooth pieces).
// - The half vector comes from ggx_half_vector_t, which has no 1 - cos^2 cancellation (see
//   hammersley.glsl): at roughness 0 it is exactly +z on any driver.
// - phi is the exact radical inverse, shifted to cell midpoints.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform writeonly image2D u_target;
uniform int u_size;
uniform int u_samples;

void main() {
    ivec2 id = ivec2(gl_GlobalInvocationID.xy);
    if (id.x >= u_size || id.y >= u_size) return;
    float n_dot_v = max(float(id.x) / float(u_size - 1), MIN_N_DOT_V);
    float r = float(id.y) / float(u_size - 1);
    float alpha = r * r;
    vec3 v = vec3(sqrt(1.0 - n_dot_v * n_dot_v), 0.0, n_dot_v);
    float a = 0.0, b = 0.0, c = 0.0, e_sheen = 0.0;
    uint count = uint(u_samples);
    float inv_count = 1.0 / float(count);
    for (uint i = 0u; i < count; ++i) {
        // Specular: l = reflect(-v, h), h ~ D(h) NdotH; weight f cos / pdf = Vis 4 VdotH NdotL / NdotH,
        // times du/dt = 2 t for the change of variable.
        float t = (float(count - i) - 0.5) * inv_count;
        float phi = 2.0 * PI * (radical_inverse(i) + 0.5 * inv_count);
        vec3 h = ggx_half_vector_t(t, phi, alpha);
        vec3 l = reflect(-v, h);
        float n_dot_l = l.z;
        float v_dot_h = dot(v, h);
        if (n_dot_l > 0.0 && v_dot_h > 0.0) {
            float w = visibility_ibl(n_dot_l, n_dot_v, alpha) * 4.0 * v_dot_h * n_dot_l / h.z * (2.0 * t);
            float fc = pow5_one_minus(v_dot_h);
            a += (1.0 - fc) * w;
            b += fc * w;
        }
        // Lambert weight of the dielectric mix, cosine-weighted l (a smooth integrand).
        vec2 u = hammersley(i, count);
        float cos_t = sqrt(1.0 - u.x), sin_t = sqrt(u.x), phi_d = 2.0 * PI * u.y;
        vec3 ld = vec3(sin_t * cos(phi_d), sin_t * sin(phi_d), cos_t);
        float vh = abs(dot(v, normalize(v + ld)));
        c += 1.0 - (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * pow5_one_minus(vh));
#if SHEEN
        // The sheen's albedo E_s = int D_charlie V_sheen cos dl, r clamped as the shading clamps
        // it: h drawn from D_charlie cos(theta_h) (sin theta_h = u^(alpha / (2 alpha + 1))),
        // l = reflect(-v, h), weight f cos / pdf = V_sheen NdotL 4 VdotH / NdotH. u on cell
        // midpoints: at u = 0 h is N, where a smooth sheen has no lobe, and that one sample
        // added 1 / N to E_s at r 0 and N.V 1, where E_s is 0.
        float alpha_s = sq(max(r, MIN_PERCEPTUAL_ROUGHNESS));
        float sin_h = pow(u.x + 0.5 * inv_count, alpha_s / (2.0 * alpha_s + 1.0));
        vec3 hs = vec3(sin_h * cos(phi_d), sin_h * sin(phi_d), sqrt(max(1.0 - sin_h * sin_h, 0.0)));
        vec3 ls = reflect(-v, hs);
        float vh_s = dot(v, hs);
        if (ls.z > 0.0 && vh_s > 0.0 && hs.z > 0.0)
            e_sheen += v_sheen(ls.z, n_dot_v, alpha_s) * ls.z * 4.0 * vh_s / hs.z;
#endif
    }
#if SHEEN
    imageStore(u_target, id, vec4(a, b, c, e_sheen) / float(count));
#else
    imageStore(u_target, id, vec4(vec3(a, b, c) / float(count), 1.0));
#endif
}
