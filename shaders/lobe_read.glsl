// Set while one of the floor's lobe samples shades its sphere (stage_bounce.glsl): the
// sphere's reflections are then read blurred over the samples' spacing (g_reflection_blur, a
// perceptual roughness that ibl.glsl's reads do not go below), and its whole light is read,
// its coat's images of the sky too (floor_lobe_reads: the bounce rays leave those to the
// closed form); of the lights, the share the rays resolve, as the rays (shade.glsl).
// Only the reads blur: the material, its Fresnel and its layers stay as they are.
float g_reflection_blur = 0.0;

bool floor_lobe_reads() {
    return g_reflection_blur > 0.0;
}
