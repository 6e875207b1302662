#include "common.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "surface_shading.glsl"
#include "cubemap.glsl"

// The stage probe of the cells stage: the radiance a cell's sphere sees from its centre, for
// its IBL. Above the floor's plane, the environment; below, its own floor as the chart shades
// it (lit by the environment's IBL and the lights, darkened by the sphere's occlusion and
// shadow). Every cell has the same stage, so one probe lights every sphere; the probe is then
// GGX-prefiltered and projected to SH9 like the environment.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform writeonly imageCube u_target;
uniform int u_size;

void main() {
    ivec3 id = ivec3(gl_GlobalInvocationID);
    if (id.x >= u_size || id.y >= u_size) return;
    vec3 d = cube_direction(id.z, vec2(id.xy) + 0.5, float(u_size));
    vec3 radiance = env_radiance(d);
#if HAS_GROUND
    if (d.y < 0.0) {
        vec3 p = d * (u_ground_y / d.y);   // the floor point seen from the sphere's centre
        // Footprint of a probe texel on the floor: its angular size times the distance.
        float pixel_size = length(p) * 2.0 / float(u_size);
        radiance = shade_ground(p, -d, pixel_size);
    }
#endif
    imageStore(u_target, id, vec4(radiance, 1.0));
}
