#include "common.glsl"
#include "cubemap.glsl"
#include "hammersley.glsl"

// The floor parallax table (floor_parallax.glsl): per sphere normal n, the irradiance the
// floor gives the sphere's point R n minus what the stage probe's irradiance (seen from the
// centre) counts for it. Both see the same sky (a sphere hides none of its own point's
// hemisphere); below the horizon the point sees the floor where its ray meets it, the probe
// where the centre's ray of the same direction does: nearer the contact, its shadow and its
// occlusion for the lower half, farther out for the upper. The probe at that floor point is
// read along the centre's direction to it, level 0 (a blurred level mixes the contact's dark
// into the lit floor: 128 samples per pixel at lods 0, 0.12, 0.25, 0.4 of the chain measured
// 0.0299, 0.0300, 0.0305, 0.0316 mean FLIP on the default chart). Cosine-weighted Hammersley
// directions, the same for every texel so the table varies smoothly over n.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform writeonly imageCube u_target;
uniform samplerCube u_probe;   // the stage probe's prefiltered cube (level 0: the probe itself)
uniform int u_size;
uniform int u_samples;
uniform float u_radius;
uniform float u_ground_y;

void main() {
    ivec3 id = ivec3(gl_GlobalInvocationID);
    if (id.x >= u_size || id.y >= u_size) return;
    vec3 n = cube_direction(id.z, vec2(id.xy) + 0.5, float(u_size));
    vec3 point = n * u_radius;
    vec3 t, b;
    basis(n, t, b);
    uint count = uint(u_samples);
    vec3 sum = vec3(0.0);
    for (uint i = 0u; i < count; ++i) {
        vec2 u = hammersley(i, count);   // cosine-distributed: r = sqrt(u.x) on the tangent disc
        float r = sqrt(u.x), phi = 2.0 * PI * u.y;
        vec3 d = r * (cos(phi) * t + sin(phi) * b) + sqrt(max(1.0 - u.x, 0.0)) * n;
        if (d.y >= 0.0) continue;   // the sky: the same from the point as from the centre
        vec3 floor_point = point + d * ((u_ground_y - point.y) / d.y);
        sum += textureLod(u_probe, normalize(floor_point), 0.0).rgb - textureLod(u_probe, d, 0.0).rgb;
    }
    // E = pi * mean of L over cosine-distributed directions (pdf cos / pi).
    imageStore(u_target, id, vec4(sum * (PI / float(count)), 1.0));
}
