// The DFG lookup table: (A, B, C, E_s) at (NdotV, perceptual roughness), linear float data,
// CLAMP_TO_EDGE. A, B: split-sum specular scale and bias (F = 1); E = A + B.
// C: the weight the glTF dielectric mix leaves to Lambert under uniform light.
// E_s: the sheen's directional albedo (lobes.glsl), baked where SHEEN is composed in.
uniform sampler2D u_dfg;

vec2 dfg_uv(float n_dot_v, float perceptual_roughness) {
    vec2 size = vec2(textureSize(u_dfg, 0));
    return (vec2(n_dot_v, perceptual_roughness) * (size - 1.0) + 0.5) / size;
}

vec3 dfg_lookup(float n_dot_v, float perceptual_roughness) {
    return texture(u_dfg, dfg_uv(n_dot_v, perceptual_roughness)).rgb;
}

float dfg_sheen_lookup(float n_dot_v, float sheen_perceptual_roughness) {
    return texture(u_dfg, dfg_uv(n_dot_v, sheen_perceptual_roughness)).a;
}
