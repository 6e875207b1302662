#include "common.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "ggx.glsl"
#include "visibility.glsl"
#include "dfg.glsl"
#include "brdf.glsl"
#include "material.glsl"
#include "ibl.glsl"
#include "ground_ibl.glsl"

// The ground's IBL table (read by ground_ibl.glsl): per view direction, the environment's
// light reflected by the ground material. The specular lobe from IBL_PIXEL_SAMPLES filtered
// samples of the prefiltered map with GGX visible normals (ibl_sampled.glsl's estimator, which
// tends to the exact integral as the count grows); the irradiance is one number for the whole
// floor, summed exactly over the environment's texels with its SH9 (sh_main.glsl). The split
// sum this replaces put the far floor up to 8 % low (one V = N lobe read along R, at grazing
// angles).
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform writeonly image2D u_target;
uniform int u_size;

void main() {
    ivec2 id = ivec2(gl_GlobalInvocationID.xy);
    if (id.x >= u_size || id.y >= u_size) return;
    vec3 v = ground_view_direction((vec2(id) + 0.5) / float(u_size));
    vec3 n = vec3(0.0, 1.0, 0.0);
    Material m = ground_material();
    float n_dot_v = max(v.y, MIN_N_DOT_V);
    vec3 dfg = dfg_lookup(n_dot_v, m.perceptual_roughness);
    SampledSpecular s = sampled_specular(n, v, n_dot_v, m.alpha);
    imageStore(u_target, id, vec4(ibl_mix(m, dfg, s.mean_a, s.mean_b, u_floor_irradiance_over_pi), 1.0));
}
