// Direction sampling for the reference path tracer: cosine-weighted hemisphere, GGX visible
// normals (Heitz 2018), uniform cone (a sun disc), and the power heuristic. Local frames have
// the normal on +z; every pdf is per unit solid angle.

vec3 to_world(vec3 local, vec3 n) {
    vec3 t, b;
    basis(n, t, b);
    return local.x * t + local.y * b + local.z * n;
}

vec3 to_local(vec3 d, vec3 n) {
    vec3 t, b;
    basis(n, t, b);
    return vec3(dot(d, t), dot(d, b), dot(d, n));
}

// pdf = cos(theta) / pi.
vec3 sample_cosine_hemisphere(vec2 u) {
    float r = sqrt(u.x), phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(1.0 - u.x, 0.0)));
}

// Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (JCGT 7(4)): a half vector
// h drawn with density D_v(h) = G1(v) max(0, v.h) D(h) / v.z. v_local.z must be >= 0.
vec3 sample_ggx_vndf(vec3 v_local, float alpha, vec2 u) {
    vec3 vh = normalize(vec3(alpha * v_local.x, alpha * v_local.y, max(v_local.z, 1e-7)));
    float len2 = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = len2 > 0.0 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(len2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(u.x), phi = 2.0 * PI * u.y;
    float p1 = r * cos(phi), p2 = r * sin(phi);
    float s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * p2;
    vec3 nh = p1 * t1 + p2 * t2 + sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0)) * vh;
    return normalize(vec3(alpha * nh.x, alpha * nh.y, max(nh.z, 0.0)));
}

// pdf of l = reflect(-v, h) with h from sample_ggx_vndf: G1(v) D(h) / (4 NdotV), written as
// D / (2 (NdotV + sqrt(a2 + (1 - a2) NdotV^2))) so that it stays finite at NdotV = 0.
// d_ggx is the NDF of ggx.glsl, called exactly as brdf_cos calls it (the vector form), so D
// cancels in f / pdf even at the peak of near-mirror lobes.
float pdf_ggx_vndf_reflection(float n_dot_v, vec3 n, vec3 h, float alpha) {
    float a2 = alpha * alpha;
    float lambda_denominator = n_dot_v + sqrt(a2 + (1.0 - a2) * n_dot_v * n_dot_v);
    return d_ggx(n, h, alpha) / (2.0 * lambda_denominator);
}

// Uniform direction inside the cone of half-angle theta around axis; one_minus_cos_theta is
// passed as 2 sin^2(theta / 2) so that tiny cones keep their precision. pdf = 1 / (2 pi (1 - cos)).
vec3 sample_cone(vec3 axis, float one_minus_cos_theta, vec2 u) {
    float omc = u.x * one_minus_cos_theta;
    float cos_t = 1.0 - omc;
    float sin_t = sqrt(max(omc * (2.0 - omc), 0.0));
    float phi = 2.0 * PI * u.y;
    return normalize(to_world(vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t), axis));
}

// Veach's power heuristic for one sample from each of two techniques: weight of the one with
// pdf_a. Written as a ratio so very large pdfs (near-mirror lobes) do not overflow.
float power_heuristic(float pdf_a, float pdf_b) {
    if (pdf_a <= 0.0) return 0.0;
    float r = pdf_b / pdf_a;
    return 1.0 / (1.0 + r * r);
}
