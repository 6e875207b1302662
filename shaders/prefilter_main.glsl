#include "common.glsl"
#include "ggx.glsl"
#if PREFILTER_KERNEL == brdf
#include "visibility.glsl"
#endif
#include "cubemap.glsl"
#include "hammersley.glsl"

// GGX-prefiltered radiance for one mip level (V = N = R), with filtered importance sampling:
// each sample reads the source mip whose texel solid angle matches the sample's, so a small
// bright feature is integrated, not hit or missed (no +1 lod bias: it over-blurred every level,
// +21 % at r = 1; the sample counts per level, ibl.prefilter_samples, keep the lods low).
// PREFILTER_KERNEL picks the weight of l = reflect(-n, h), h ~ D cos(theta_h):
// - cosine: NdotL (Karis 2013), the kernel the sampled path filters with; at r = 1 it is the
//   normalised cosine lobe, so that level holds the irradiance E(n) / pi;
// - brdf: NdotL Vis(NdotL, NdotV = 1), the whole specular lobe f cos at V = N. Its heavier
//   grazing part is closer to the lobes the split sum reads it for (seen off-normal they are
//   wider than D alone): under tests/test_ibl_accuracy.py's environment it cuts the split sum's
//   error on r = 1 metals from 7.4 to 2.1 % (float64 model).
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform writeonly imageCube u_target;
uniform samplerCube u_source;      // the baked environment with a full mip chain
uniform int u_size;                // size of the level written
uniform float u_source_size;       // level-0 size of the source
uniform float u_perceptual_roughness;
uniform int u_samples;

void main() {
    ivec3 id = ivec3(gl_GlobalInvocationID);
    if (id.x >= u_size || id.y >= u_size) return;
    vec3 n = cube_direction(id.z, vec2(id.xy) + 0.5, float(u_size));
    float alpha = sq(max(u_perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS));
    if (u_perceptual_roughness == 0.0) {   // the mirror level is the environment itself
        imageStore(u_target, id, vec4(textureLod(u_source, n, 0.0).rgb, 1.0));
        return;
    }
    vec3 t, b;
    basis(n, t, b);
    float texel_solid = 4.0 * PI / (6.0 * u_source_size * u_source_size);
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    uint count = uint(u_samples);
    for (uint i = 0u; i < count; ++i) {
        vec3 h_local = ggx_half_vector(hammersley(i, count), alpha);
        vec3 h = t * h_local.x + b * h_local.y + n * h_local.z;
        vec3 l = reflect(-n, h);
        float n_dot_l = dot(n, l);
        if (n_dot_l <= 0.0) continue;
        float n_dot_h = h_local.z;
        float pdf = d_ggx(n_dot_h, alpha) * 0.25;          // V = N: pdf(l) = D / 4
        float sample_solid = 1.0 / (float(count) * pdf + 1e-8);
        float lod = max(0.5 * log2(sample_solid / texel_solid), 0.0);
#if PREFILTER_KERNEL == brdf
        float w = n_dot_l * visibility_ibl(n_dot_l, 1.0, alpha);
#else
        float w = n_dot_l;
#endif
        sum += textureLod(u_source, l, lod).rgb * w;
        weight += w;
    }
    imageStore(u_target, id, vec4(sum / max(weight, 1e-8), 1.0));
}
