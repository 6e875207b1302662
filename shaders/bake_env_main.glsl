#include "common.glsl"
#include "env.glsl"
#include "cubemap.glsl"

// Bake the environment into level 0 of a float cubemap.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform writeonly imageCube u_target;
uniform int u_size;

void main() {
    ivec3 id = ivec3(gl_GlobalInvocationID);
    if (id.x >= u_size || id.y >= u_size) return;
    vec3 d = cube_direction(id.z, vec2(id.xy) + 0.5, float(u_size));
    imageStore(u_target, id, vec4(env_radiance(d), 1.0));
}
