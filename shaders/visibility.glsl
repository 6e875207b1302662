// BRDF_MODEL picks the visibility term: gltf (height-correlated Smith) or schlick_ggx (the
// seeds' Schlick-GGX, k = (r+1)^2/8 for direct light, k = alpha/2 for IBL). The DFG LUT is
// built with visibility_ibl, so LUT and shading never disagree on G.

// Visibility for punctual lights.
float visibility_direct(float n_dot_l, float n_dot_v, float perceptual_roughness, float alpha) {
#if BRDF_MODEL == gltf
    return vis_smith_ggx_correlated(n_dot_l, n_dot_v, alpha);
#elif BRDF_MODEL == schlick_ggx
    return vis_schlick_ggx(n_dot_l, n_dot_v, sq(perceptual_roughness + 1.0) / 8.0);
#endif
}

// Visibility for the image-based term (the DFG LUT is built with this one).
float visibility_ibl(float n_dot_l, float n_dot_v, float alpha) {
#if BUG_IBL_DIRECT_K
    return vis_schlick_ggx(n_dot_l, n_dot_v, sq(sqrt(alpha) + 1.0) / 8.0);   // the punctual-light k
#elif BRDF_MODEL == gltf
    return vis_smith_ggx_correlated(n_dot_l, n_dot_v, alpha);
#elif BRDF_MODEL == schlick_ggx
    return vis_schlick_ggx(n_dot_l, n_dot_v, 0.5 * alpha);
#endif
}
