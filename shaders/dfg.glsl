// The DFG lookup table: (A, B, C) at (NdotV, perceptual roughness), linear float data,
// CLAMP_TO_EDGE. A, B: split-sum specular scale and bias (F = 1); E = A + B.
// C: the weight the glTF dielectric mix leaves to Lambert under uniform light.
uniform sampler2D u_dfg;

vec3 dfg_lookup(float n_dot_v, float perceptual_roughness) {
    vec2 size = vec2(textureSize(u_dfg, 0));
    vec2 uv = (vec2(n_dot_v, perceptual_roughness) * (size - 1.0) + 0.5) / size;
    return texture(u_dfg, uv).rgb;
}
