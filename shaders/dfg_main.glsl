#include "common.glsl"
#include "ggx.glsl"
#include "visibility.glsl"
#include "hammersley.glsl"

// The DFG LUT (REFERENCE.md §2) by GGX importance sampling with the shading's visibility:
// texel (i, j) holds (A, B, C) at NdotV = i/(size-1), perceptual roughness = j/(size-1): the
// inverse of dfg_lookup, which puts 0 and 1 on the first and last texel centres.
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
    float a = 0.0, b = 0.0, c = 0.0;
    uint count = uint(u_samples);
    for (uint i = 0u; i < count; ++i) {
        vec2 u = hammersley(i, count);
        // Specular: l = reflect(-v, h), h ~ D(h) NdotH; weight f cos / pdf = Vis 4 VdotH NdotL / NdotH.
        vec3 h = ggx_half_vector(u, alpha);
        vec3 l = reflect(-v, h);
        float n_dot_l = l.z;
        float v_dot_h = dot(v, h);
        if (n_dot_l > 0.0 && v_dot_h > 0.0) {
            float w = visibility_ibl(n_dot_l, n_dot_v, alpha) * 4.0 * v_dot_h * n_dot_l / h.z;
            float fc = pow5_one_minus(v_dot_h);
            a += (1.0 - fc) * w;
            b += fc * w;
        }
        // Lambert weight of the dielectric mix, cosine-weighted l.
        float cos_t = sqrt(1.0 - u.x), sin_t = sqrt(u.x), phi = 2.0 * PI * u.y;
        vec3 ld = vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t);
        float vh = abs(dot(v, normalize(v + ld)));
        c += 1.0 - (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * pow5_one_minus(vh));
    }
    imageStore(u_target, id, vec4(vec3(a, b, c) / float(count), 1.0));
}
