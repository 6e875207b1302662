// The light a cells-stage sphere gets back from its floor of its own light (sphere -> floor ->
// sphere). The stage probe shows the floor as every cell's sphere would leave it, without the
// cell's bounce (that depends on the cell's material), so the spheres were 5-9 % dark where
// they face the floor. A sphere of uniform radiance K resting on a Lambertian floor of albedo
// rho lights it to the radiance rho K (R / d)^3 at distance d from its centre; the sphere's
// point with normal n gets back the irradiance rho K G(n.y), G tabulated in float64
// (shading.cells FLOOR_RETURN_G), and the radiance rho K (R / d)^3 along its mirror direction.
// K is the sphere's radiance towards the floor beside it: its diffuse albedo times the mean of
// the irradiance at the point (which lights the floor beside it most) and over its lower half
// (which still lights it when a light from above leaves the point dark: the SH's mean over the
// lower half's normals is sh0 - sh1 / 2, a light's E (1 - l.y) / 4), over pi; plus its
// specular albedo times each light mirrored every way (a sphere spreads a parallel beam
// evenly: E / 4 over pi). The sky a metal mirrors is left out: near its contact it mirrors the
// floor its own occlusion darkens (with it, the floor's light seen straight down, a metal's
// lower half went from 6 % to 10 % bright under the studio without lights).
// The default chart's FLIP against its 8192-spp reference: 0.0351 without the return, 0.0330
// with it (0.0325 with that sky; 0.0327 with one K for both lobes).
uniform float u_floor_return[FLOOR_RETURN_STEPS];

float floor_return_g(float n_y) {
    float x = (n_y + 1.0) * 0.5 * float(FLOOR_RETURN_STEPS - 1);
    int i = min(int(x), FLOOR_RETURN_STEPS - 2);
    return mix(u_floor_return[i], u_floor_return[i + 1], x - float(i));
}

// At the sphere's point with geometric normal n_geo seen along v, of material m (dfg its LUT
// entry there). K and the point's response are each linear in metallic, their product is
// not; it is taken at the dielectric and at the metal end and mixed by metallic, as glTF
// mixes the two BRDFs, so that the sphere plate (which shades the two ends) holds it exactly.
vec3 floor_return(Material m, vec3 n_geo, vec3 v, vec3 dfg) {
    vec3 r = reflect(-v, n_geo);
    // Above n.y = 0.75 G is under 0.002 (pi at the foot), and a mirror ray going up meets no
    // floor: nothing to add worth the work.
    if (n_geo.y > 0.75 && r.y >= 0.0) return vec3(0.0);
    vec3 point_e = sh_irradiance(n_geo);
#if FLOOR_PARALLAX
    point_e += floor_parallax_irradiance(n_geo);
#endif
    vec3 diffuse_e = 0.5 * (point_e + (u_sh[0] - 0.5 * u_sh[1]));
    vec3 specular_e = vec3(0.0);   // the lights' mirrored glow
#if NUM_DIR_LIGHTS > 0
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i) {
        vec3 l = u_dir_light_direction[i];
        diffuse_e += u_dir_light_illuminance[i] * (0.5 * max(dot(n_geo, l), 0.0) + 0.125 * (1.0 - l.y));
        specular_e += u_dir_light_illuminance[i] * 0.25;
    }
#endif
#if NUM_POINT_LIGHTS > 0
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {
        vec3 to_light = u_point_light_position[i] - n_geo * u_radius;
        float dist = length(to_light);
        vec3 l = to_light / dist;
        vec3 e = u_point_light_intensity[i] * point_falloff(dist, u_point_light_range[i]);
        diffuse_e += e * (0.5 * max(dot(n_geo, l), 0.0) + 0.125 * (1.0 - l.y));
        specular_e += e * 0.25;
    }
#endif
    // The floor's radiance where the mirror ray from the sphere's point meets it (the lobe's
    // spread left out: the floor's light falls off smoothly), and its irradiance / pi there.
    float mirrored = 0.0;
    if (r.y < 0.0) {
        vec3 x = n_geo * u_radius;
        float near = u_radius / length(x + r * ((-u_radius - x.y) / r.y));
        mirrored = near * near * near;
    }
    float spread = floor_return_g(n_geo.y) * INV_PI;
    // The albedos at each end (ibl_mix is linear in the radiances it is given).
    Material dielectric = m, metal = m;
    dielectric.metallic = 0.0;
    metal.metallic = 1.0;
    vec3 diffuse_0 = ibl_mix(dielectric, dfg, vec3(0.0), vec3(0.0), vec3(1.0));
    vec3 specular_0 = ibl_mix(dielectric, dfg, vec3(1.0), vec3(1.0), vec3(0.0));
    vec3 specular_1 = ibl_mix(metal, dfg, vec3(1.0), vec3(1.0), vec3(0.0));
    vec3 end_0 = (diffuse_0 * diffuse_e + specular_0 * specular_e) * (specular_0 * mirrored + diffuse_0 * spread);
    vec3 end_1 = specular_1 * specular_e * specular_1 * mirrored;
    return u_ground_color * INV_PI * mix(end_0, end_1, m.metallic);
}
