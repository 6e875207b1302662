// The cells stage's floor's glossy lobe where its sphere stands in it: a few fixed samples
// (BOUNCE_SPECULAR_SAMPLES on the chart's floor, fewer in the bounce cache) by visible normals
// (Heitz 2018), f cos / pdf = F Vis N.L 2 lambda (D cancels, as ibl_sampled.glsl). ao.glsl
// takes the sky the sphere hides from the lobe with them and stage_bounce.glsl gives the
// sphere's light back with the same ones, so where the sphere looks like the sky behind it
// the two cancel exactly. Fixed samples meet the sphere or miss
// it all at once as the floor point moves (rings round it, or dots under a mirror floor): each
// stands for a cone as wide as the samples' spacing (its reflected directions ~2 alpha across)
// and counts by how much of that cone the sphere's disc covers.
#include "hammersley.glsl"
#include "sampling.glsl"

struct FloorLobeSample {
    vec3 w;          // the sample's direction from the floor point
    vec3 on_sphere;  // w, or where it passes beside the disc the nearest direction just inside it
    float weight;    // F Vis N.L 2 lambda times the disc's cover of its cone (0: nothing to read)
};

// The samples' cone: the sky or the sphere is read as seen over it.
float floor_lobe_cone(float alpha, int count) {
    return 2.0 * alpha * inversesqrt(float(max(count, 1))) + 1e-3;
}

// Sample k of `count` of the floor's lobe at floor point q (the sphere at the origin) seen
// along v.
FloorLobeSample floor_lobe_sample(int k, int count, vec3 q, vec3 v, float alpha) {
    FloorLobeSample s = FloorLobeSample(vec3(0.0, 1.0, 0.0), vec3(0.0, 1.0, 0.0), 0.0);
    float n_dot_v = max(v.y, MIN_N_DOT_V);
    vec3 v_local = vec3(v.x, v.z, n_dot_v);   // the floor's frame: normal +y as local z
    vec3 h = sample_ggx_vndf(v_local, alpha, hammersley(uint(k), uint(max(count, 1))));
    vec3 l = 2.0 * dot(v_local, h) * h - v_local;
    if (l.z <= 0.0) return s;
    s.w = s.on_sphere = vec3(l.x, l.z, l.y);
    float dist = length(q);
    vec3 axis = -q / dist;
    float disc = asin(min(u_radius / dist, 1.0));   // the sphere's angular radius from q
    float cone = floor_lobe_cone(alpha, count);
    float off = acos(clamp(dot(s.w, axis), -1.0, 1.0));   // from the disc's centre
    float cover = 1.0 - smoothstep(disc - cone, disc + cone, off);
    if (cover <= 0.0) return s;
    if (off > 0.999 * disc) {
        vec3 side = s.w - axis * dot(s.w, axis);
        float len = length(side);
        if (len > 1e-6) s.on_sphere = axis * cos(0.999 * disc) + side * (sin(0.999 * disc) / len);
    }
    float a2 = alpha * alpha;
    float lambda_denominator = n_dot_v + sqrt(a2 + (1.0 - a2) * n_dot_v * n_dot_v);
    s.weight = cover * visibility_ibl(l.z, n_dot_v, alpha) * l.z * 2.0 * lambda_denominator
             * fresnel_schlick(vec3(DIELECTRIC_F0), saturate(dot(v_local, h))).x;
    return s;
}
