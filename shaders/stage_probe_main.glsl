#include "common.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "surface_shading.glsl"
#include "cubemap.glsl"

// The stage probe: the radiance seen from the origin, for the spheres' IBL. Above the floor's
// plane, the environment; below, the floor as the chart shades it (lit by the environment's
// IBL and the lights, darkened by the spheres' occlusion and shadows). Cells stage: the origin
// is every cell's sphere's centre, so one probe lights every sphere. Shared stage: the origin
// is the grid's centre, and each sphere reads the probe towards the floor point its ray meets
// (scene.glsl stage_parallax): the floor and its shadows where they are, seen from elsewhere.
// The probe is then GGX-prefiltered and projected to SH9 like the environment.

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
        vec3 p = d * (u_ground_y / d.y);   // the floor point seen from the origin
        // Footprint of a probe texel on the floor: its angular size times the distance.
        float pixel_size = length(p) * 2.0 / float(u_size);
#if STAGE == cells
        radiance = shade_ground(p, normalize(floor_viewer(p) - p), pixel_size);   // scene.glsl
#else
        radiance = shade_ground(p, -d, pixel_size);
#endif
    }
#endif
    imageStore(u_target, id, vec4(radiance, 1.0));
}
