#include "common.glsl"
#include "cubemap.glsl"

// A light orbit's stage probe, one prefiltered level (IBLBaker.turning_light): the probe is
// linear in its lights and the stage is symmetric about the vertical through the sphere, so
// with the key light turned about it the key light's share turns with it (prefiltering commutes
// with the turn: the GGX kernel depends on angles only). From two bakes of the first frame --
// u_full (every light) and u_rest (the key light off) -- every later frame's probe is
// rest(d) + full(T d) - rest(T d), T the turn back to the first frame.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform writeonly imageCube u_target;
uniform samplerCube u_full;
uniform samplerCube u_rest;
uniform mat3 u_turn_back;
uniform int u_size;                // size of the level written
uniform float u_lod;

void main() {
    ivec3 id = ivec3(gl_GlobalInvocationID);
    if (id.x >= u_size || id.y >= u_size) return;
    vec3 d = cube_direction(id.z, vec2(id.xy) + 0.5, float(u_size));
    vec3 back = u_turn_back * d;
    vec4 key = textureLod(u_full, back, u_lod) - textureLod(u_rest, back, u_lod);
    imageStore(u_target, id, vec4(textureLod(u_rest, d, u_lod).rgb + key.rgb, 1.0));
}
