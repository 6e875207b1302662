#include "common.glsl"
#include "env.glsl"
#include "sampling_env.glsl"

// The environment's radiance averaged over each texel of an equirectangular grid (u_supersample^2
// points per texel): the table reference.py turns into sampling CDFs.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform writeonly image2D u_target;
uniform ivec2 u_size;
uniform int u_supersample;

void main() {
    ivec2 id = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(id, u_size))) return;
    vec3 sum = vec3(0.0);
    for (int b = 0; b < u_supersample; ++b)
        for (int a = 0; a < u_supersample; ++a) {
            vec2 uv = (vec2(id) + (vec2(a, b) + 0.5) / float(u_supersample)) / vec2(u_size);
            sum += env_radiance(equirect_direction(uv));
        }
    imageStore(u_target, id, vec4(sum / float(u_supersample * u_supersample), 1.0));
}
