// The floor seen from the sphere's point, not its centre (FLOOR_PARALLAX, cells stage). The
// stage probe's irradiance sees the floor from the sphere's centre, where the contact's shadow
// and occlusion fill the view below; the lower half's own points see the lit floor in front of
// them. A table over the sphere's normal (floor_parallax_main.glsl, baked from the probe)
// holds the irradiance the probe's misses; a white dielectric's lower half under the key light
// alone went from 0.857 to 0.983 of the path tracer's (tests/test_stage.py), the default
// chart's FLIP against its 16384-spp reference from 0.0327 to 0.0296.
uniform samplerCube u_floor_parallax;

// What to add to the probe's irradiance E(n) at the sphere's point with normal n. The diffuse
// only: with the bounce cache and a path tracer carried to convergence, adding it to the
// two-lobe lookup's tail too (read along N) left an r 0.5 white metal's lower half 1.7 %
// bright against 0.3 % without (tests/test_stage.py).
vec3 floor_parallax_irradiance(vec3 n) {
    return textureLod(u_floor_parallax, n, 0.0).rgb;
}
