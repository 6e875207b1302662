// SDF normals. The tetrahedron technique (Inigo Quilez) needs 4 SDF evaluations; central
// differences need 6. eps follows the pixel footprint so fp32 cancellation stays invisible.
vec3 sdf_normal(vec3 p, float eps) {
#if NORMAL_METHOD == tetrahedron
    const vec2 k = vec2(1.0, -1.0);
    return normalize(k.xyy * sdf_spheres(p + k.xyy * eps) + k.yyx * sdf_spheres(p + k.yyx * eps) +
                     k.yxy * sdf_spheres(p + k.yxy * eps) + k.xxx * sdf_spheres(p + k.xxx * eps));
#elif NORMAL_METHOD == central
    vec2 e = vec2(eps, 0.0);
    return normalize(vec3(sdf_spheres(p + e.xyy) - sdf_spheres(p - e.xyy),
                          sdf_spheres(p + e.yxy) - sdf_spheres(p - e.yxy),
                          sdf_spheres(p + e.yyx) - sdf_spheres(p - e.yyx)));
#endif
}
