// The split sum's lobe table, written by `python -m sdfpbr.oracle.lobe_fit` (do not edit):
// per perceptual roughness (rows, r = 0.2 .. 1 step 0.1) and N.V (columns, 0.1 .. 0.9 step
// 0.2), the core's two reads' offset, its width scale and the tail's share, fitted to the
// float64 lobe average under random three-lobe skies. On held-out skies the mean relative
// error is 5.33 % over the nodes (the one-read ramps: 6.61 %).
const float LOBE_TABLE_DELTA[45] = float[](
    0.100, 0.100, 0.100, 0.000, 0.000,
    0.200, 0.100, 0.100, 0.100, 0.000,
    0.200, 0.200, 0.200, 0.100, 0.100,
    0.300, 0.300, 0.200, 0.200, 0.200,
    0.400, 0.300, 0.200, 0.200, 0.200,
    0.400, 0.400, 0.400, 0.300, 0.100,
    0.400, 0.400, 0.100, 0.200, 0.200,
    0.400, 0.100, 0.100, 0.100, 0.000,
    0.100, 0.400, 0.400, 0.400, 0.400);
const float LOBE_TABLE_CORE[45] = float[](
    0.500, 0.800, 0.700, 1.000, 1.000,
    0.500, 0.700, 0.800, 0.900, 1.000,
    0.500, 0.700, 0.800, 0.900, 0.900,
    0.600, 0.600, 0.700, 0.800, 0.900,
    0.700, 0.700, 0.800, 0.800, 0.900,
    0.600, 0.700, 0.700, 0.800, 0.900,
    0.700, 0.800, 0.900, 0.900, 0.900,
    0.800, 1.000, 1.000, 0.900, 1.000,
    0.700, 0.800, 0.900, 1.000, 1.000);
const float LOBE_TABLE_TAIL[45] = float[](
    0.025, 0.000, 0.000, 0.000, 0.000,
    0.075, 0.025, 0.025, 0.000, 0.000,
    0.150, 0.075, 0.050, 0.025, 0.050,
    0.200, 0.150, 0.125, 0.100, 0.075,
    0.200, 0.200, 0.175, 0.175, 0.125,
    0.375, 0.275, 0.275, 0.200, 0.200,
    0.250, 0.200, 0.200, 0.175, 0.250,
    0.275, 0.150, 0.025, 0.200, 0.050,
    0.475, 0.000, 0.000, 0.000, 0.600);

// Bilinear over the grid, clamped to its edges.
LobeFit lobe_table(float perceptual_roughness, float n_dot_v) {
    float x = clamp((perceptual_roughness - 0.2) / 0.1, 0.0, 8.0);
    float y = clamp((n_dot_v - 0.1) / 0.2, 0.0, 4.0);
    int i = min(int(x), 7), j = min(int(y), 3);
    float fx = x - float(i), fy = y - float(j);
    int k = i * 5 + j;
    vec4 w = vec4((1.0 - fx) * (1.0 - fy), (1.0 - fx) * fy, fx * (1.0 - fy), fx * fy);
    ivec4 at = ivec4(k, k + 1, k + 5, k + 6);
    return LobeFit(dot(w, vec4(LOBE_TABLE_TAIL[at.x], LOBE_TABLE_TAIL[at.y], LOBE_TABLE_TAIL[at.z], LOBE_TABLE_TAIL[at.w])),
                   dot(w, vec4(LOBE_TABLE_CORE[at.x], LOBE_TABLE_CORE[at.y], LOBE_TABLE_CORE[at.z], LOBE_TABLE_CORE[at.w])),
                   dot(w, vec4(LOBE_TABLE_DELTA[at.x], LOBE_TABLE_DELTA[at.y], LOBE_TABLE_DELTA[at.z], LOBE_TABLE_DELTA[at.w])));
}
