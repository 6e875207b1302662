// Ray-sphere with the cancellation-free form (docs/model.md, geometry): qc = oc - b rd, h = R^2 - |qc|^2.
float ray_sphere(vec3 ro, vec3 rd, vec3 center, float radius) {
    vec3 oc = ro - center;
    float b = dot(oc, rd);
    vec3 qc = oc - b * rd;
    float h = radius * radius - dot(qc, qc);
    if (h < 0.0) return -1.0;
    h = sqrt(h);
    float t = -b - h;
    return t > 0.0 ? t : (-b + h > 0.0 ? -b + h : -1.0);
}
