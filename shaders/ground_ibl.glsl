// The ground's image-based lighting, read from its table (baked by ground_ibl_main.glsl). The
// ground is a plane under an environment at infinity, so its IBL term depends on the view
// direction alone: one table per environment and ground material serves every pixel, cell
// and frame. A texel stands for a view direction of the upper hemisphere's octahedral map:
// the diamond |x| + |z| <= 1 of v / |v|_1, turned 45 degrees onto the unit square.
uniform sampler2D u_ground_ibl;

vec2 ground_view_uv(vec3 v) {
    vec3 a = v / (abs(v.x) + abs(v.y) + abs(v.z));
    return 0.5 + 0.5 * vec2(a.x + a.z, a.x - a.z);
}

vec3 ground_view_direction(vec2 uv) {
    vec2 d = 2.0 * uv - 1.0;
    float x = 0.5 * (d.x + d.y), z = 0.5 * (d.x - d.y);
    return normalize(vec3(x, max(1.0 - abs(x) - abs(z), 0.0), z));
}

// IBL radiance of the unoccluded ground towards v (the caller applies the ground's AO).
vec3 ground_ibl(vec3 v) {
    return textureLod(u_ground_ibl, ground_view_uv(v), 0.0).rgb;
}
