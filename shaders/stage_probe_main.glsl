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
#if STAGE == cells
// Who looks at the floor point q through the probe: mostly the sphere's lower half, whose
// normals turn the camera's level rays steeply down onto the floor below them. So the floor's
// light is taken towards the sphere's point above q (beyond its footprint the equator point on
// q's side), not towards the centre, which sees q at a grazing angle: a glossy floor's gloss
// depends on that angle (a dark r 0.34 floor under a uniform sky: the lower half of an r 0.18
// metal 28 % too bright seen from the centre). The choice is symmetric about the vertical, as
// the light orbit's turned probe needs (turn_probe_main.glsl).
vec3 floor_viewer(vec3 q) {
    float r2 = dot(q.xz, q.xz), radius2 = u_radius * u_radius;
    if (r2 < radius2) return vec3(q.x, -sqrt(radius2 - r2), q.z);
    return vec3(q.x, 0.0, q.z) * (u_radius * inversesqrt(r2));
}
#endif

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
        radiance = shade_ground(p, normalize(floor_viewer(p) - p), pixel_size);
#else
        radiance = shade_ground(p, -d, pixel_size);
#endif
    }
#endif
    imageStore(u_target, id, vec4(radiance, 1.0));
}
