// Image-based lighting from the baked environment: GGX-prefiltered cubemap (roughness -> lod
// linear, lod = r (levels - 1), the inverse of the bake), SH9 irradiance, DFG split sum.
uniform samplerCube u_prefiltered;
uniform float u_prefiltered_lods;   // number of mip levels - 1
uniform vec3 u_sh[9];               // irradiance SH9, cosine lobe already applied

vec3 prefiltered_radiance(vec3 r_dir, float perceptual_roughness) {
    return textureLod(u_prefiltered, r_dir, perceptual_roughness * u_prefiltered_lods).rgb;
}

// Irradiance E(n) = integral of L cos (Ramamoorthi & Hanrahan 2001), never negative.
vec3 sh_irradiance(vec3 n) {
    vec3 e = u_sh[0]
           + u_sh[1] * n.y + u_sh[2] * n.z + u_sh[3] * n.x
           + u_sh[4] * (n.x * n.y) + u_sh[5] * (n.y * n.z) + u_sh[6] * (3.0 * n.z * n.z - 1.0)
           + u_sh[7] * (n.x * n.z) + u_sh[8] * (n.x * n.x - n.y * n.y);
    return max(e, vec3(0.0));
}

// Split-sum IBL for the glTF mix; each specular lobe compensated with its own f0.
vec3 shade_ibl(Material m, vec3 n, vec3 v, float n_dot_v, vec3 dfg) {
    vec3 r_dir = reflect(-v, n);
    vec3 radiance = prefiltered_radiance(r_dir, m.perceptual_roughness);
    vec3 irradiance = sh_irradiance(n);
    float e_single = dfg.x + dfg.y;
    vec3 spec_dielectric = vec3(DIELECTRIC_F0 * dfg.x + dfg.y) * energy_compensation(vec3(DIELECTRIC_F0), e_single);
    vec3 spec_metal = (m.base_color_linear * dfg.x + dfg.y) * energy_compensation(m.base_color_linear, e_single);
#if BUG_DIFFUSE_NO_FRESNEL
    vec3 diffuse = m.base_color_linear * irradiance * INV_PI;
#else
    vec3 diffuse = m.base_color_linear * irradiance * INV_PI * dfg.z;
#endif
    vec3 metal = radiance * spec_metal;
#if BUG_METAL_DIFFUSE
    return diffuse + mix(radiance * spec_dielectric, metal, m.metallic);
#else
    return mix(diffuse + radiance * spec_dielectric, metal, m.metallic);
#endif
}
