#include "common.glsl"
#include "cubemap.glsl"

// SH9 projection of the environment, convolved with the clamped cosine (irradiance), and the
// irradiance / pi of an upward normal, the floor's, summed exactly rather than through SH9's
// band limit (a sun in the sky puts that several % off; so did the floor's 1024 cosine samples,
// a sun 2 degrees wide falling between them: the far floor 8 % bright under one 450x the sky).
// One invocation per output; it sums the source cubemap texels weighted by solid angle.
layout(local_size_x = 10) in;
layout(std430, binding = 0) buffer Coefficients { vec4 u_coefficients[10]; };
uniform samplerCube u_source;
uniform int u_source_lod;
uniform int u_size;                // size of the level read

float sh_basis(int k, vec3 d) {
    if (k == 0) return 0.282095;
    if (k == 1) return 0.488603 * d.y;
    if (k == 2) return 0.488603 * d.z;
    if (k == 3) return 0.488603 * d.x;
    if (k == 4) return 1.092548 * d.x * d.y;
    if (k == 5) return 1.092548 * d.y * d.z;
    if (k == 6) return 0.315392 * (3.0 * d.z * d.z - 1.0);
    if (k == 7) return 1.092548 * d.x * d.z;
    return 0.546274 * (d.x * d.x - d.y * d.y);
}

void main() {
    int k = int(gl_LocalInvocationID.x);
    vec3 sum = vec3(0.0);
    for (int face = 0; face < 6; ++face)
        for (int y = 0; y < u_size; ++y)
            for (int x = 0; x < u_size; ++x) {
                vec2 c = vec2(x, y) + 0.5;
                vec3 d = cube_direction(face, c, float(u_size));
                vec3 radiance = textureLod(u_source, d, float(u_source_lod)).rgb;
                float weight = k < 9 ? sh_basis(k, d) : max(d.y, 0.0) * INV_PI;
                sum += radiance * weight * texel_solid_angle(c, float(u_size));
            }
    if (k == 9) {   // the floor's irradiance / pi
        u_coefficients[9] = vec4(sum, 0.0);
        return;
    }
    // Cosine-lobe convolution A_l (pi, 2pi/3, pi/4) times the basis constants, so the
    // shader evaluates E(n) with the polynomial in ibl.glsl directly.
    const float band[9] = float[9](0.282095 * PI,
        0.488603 * 2.0 * PI / 3.0, 0.488603 * 2.0 * PI / 3.0, 0.488603 * 2.0 * PI / 3.0,
        1.092548 * PI / 4.0, 1.092548 * PI / 4.0, 0.315392 * PI / 4.0, 1.092548 * PI / 4.0, 0.546274 * PI / 4.0);
    u_coefficients[k] = vec4(sum * band[k], 0.0);
}
