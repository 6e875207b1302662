#include "bounce_split.glsl"

#if USE_IBL
// The ground's IBL: its view-direction table where the plan bakes one (GROUND_IBL: within 1 % of
// the exact integral where the split sum is up to 8 % off, at the grazing angles a far floor
// is seen at), else the split sum.
vec3 ground_ibl_term(Material m, vec3 n, vec3 v, float n_dot_v, vec3 dfg) {
#if GROUND_IBL
    return ground_ibl(v);
#else
    return shade_ibl(m, n, v, n_dot_v, dfg);
#endif
}
#endif

// What the bounce rays keep of f cos where stage_bounce.glsl mirrors the base's specular: the
// body's diffuse and, under SHEEN, the sheen's own lobe with the base scaled under it (the
// mirrored image is scaled too: sphere_mirror.glsl mirror_fresnel). Without the sheen's lobe,
// the floor beside a smooth sheened sphere read 1-2 % dark against the reference.
vec3 unmirrored_brdf_cos(Material m, vec3 n, vec3 v, vec3 l, float n_dot_v) {
    vec3 f_cos = diffuse_brdf_cos(m, n, v, l);
#if SHEEN
    float n_dot_l = dot(n, l);
    if (n_dot_l > 0.0) f_cos = sheen_layer(m, f_cos / n_dot_l, n, v, l, n_dot_v, n_dot_l) * n_dot_l;
#endif
    return f_cos;
}

// A punctual light's f cos, its specular share weighted by `specular` (1, a literal, at every
// call but the bounce's: stage_bounce.glsl takes the rest of a smooth sphere's reflection of
// the lights and of the sky in closed form).
vec3 base_lights_brdf_cos(Material m, vec3 n, vec3 v, vec3 l, float n_dot_v, float light_angle, float e_single,
                          float specular) {
    if (specular >= 1.0) return brdf_cos(m, n, v, l, n_dot_v, light_angle, e_single);
    if (specular <= 0.0) return unmirrored_brdf_cos(m, n, v, l, n_dot_v);
    return mix(unmirrored_brdf_cos(m, n, v, l, n_dot_v), brdf_cos(m, n, v, l, n_dot_v, light_angle, e_single), specular);
}

// bounce_ray (a literal): a coat's image of the light is stage_bounce.glsl's too, but for the
// share of it the rays resolve; the base under it keeps its own split.
vec3 lights_brdf_cos(Material m, vec3 n, vec3 v, vec3 l, float n_dot_v, float light_angle, float e_single,
                     float specular, bool bounce_ray) {
#if CLEARCOAT
    if (bounce_ray && m.clearcoat > 0.0) {
        Material base = m;
        base.clearcoat = 0.0;
#if BUG_CLEARCOAT_ADDS
        float kept = 1.0;
#else
        float kept = 1.0 - clearcoat_weight(m, v);
#endif
        return base_lights_brdf_cos(base, n, v, l, n_dot_v, light_angle, e_single, specular) * kept
             + clearcoat_layer(m, vec3(0.0), v, l, light_angle) * bounce_resolves(m.clearcoat_alpha);
    }
#endif
    return base_lights_brdf_cos(m, n, v, l, n_dot_v, light_angle, e_single, specular);
}


// Radiance leaving a surface point towards the camera: IBL (occluded by AO) plus punctual
// lights (shadowed on the ground where shadows are composed in).
// pixel_size: the world size of a pixel at p (texture level of detail). `ground` is a literal
// at every call (shade_sphere, shade_ground below): after inlining, each keeps only its own
// code (a runtime test let llvmpipe run the ground's occlusion for every sphere point too).
// `blocked` (a literal too): the ground's light as its sphere blocks it (occlusion, shadows);
// false gives the open floor a shadow catcher divides by. `light_spread`, `light_specular`:
// the bounce rays' (shade_sphere_for_bounce), 0 and 1 (literals) elsewhere; `bounce_ray` (a
// literal) true there.
#if SPHERE_PLATE_PASS
float g_plate_metallic = 0.0;   // the sphere plate shades each slot's sphere at metallic 0 and 1
#endif

vec3 shade_point(vec3 p, vec3 n_geo, vec3 v, ivec2 cell, float pixel_size, bool ground, float light_spread,
                 float light_specular, bool blocked, bool bounce_ray) {
#if STAGE_PROBE
    g_shading_point = p;   // for the probe's parallax correction
#endif
    Material m = ground ? ground_material() : cell_material(cell, n_geo);
#if SPHERE_PLATE_PASS
    if (!ground) m.metallic = g_plate_metallic;
#endif
    vec3 n = n_geo;
#if USE_TEXTURES
    float occlusion = 1.0;
    if (!ground) {   // glTF: texture values scale the cell's factors
        SurfaceTexels tx = sample_surface(n_geo, pixel_size, cell);
        apply_texels(m, cell, tx);
        occlusion = tx.orm.r;
        n = tx.normal;
    }
#endif
#if BUG_UNCLAMPED_NDOTV
    float n_dot_v = dot(n, v);
#else
    float n_dot_v = max(dot(n, v), MIN_N_DOT_V);
#endif
    vec3 dfg = dfg_lookup(n_dot_v, m.perceptual_roughness);
    float e_single = dfg.x + dfg.y;
    vec3 color = vec3(0.0);
#if USE_AO
    float ao = ground && !blocked ? 1.0 : ambient_occlusion(p, n_geo, cell);
#endif
#if USE_IBL
#if IBL_METHOD == sampled && !BUG_FEWTAP_IBL
    // The spheres integrate the environment per pixel.
    vec3 ibl = !ground ? shade_ibl_sampled(m, n, v, n_dot_v, dfg) : ground_ibl_term(m, n, v, n_dot_v, dfg);
#else
    vec3 ibl = !ground ? shade_ibl(m, n, v, n_dot_v, dfg) : ground_ibl_term(m, n, v, n_dot_v, dfg);
#endif
#if !BUG_FEWTAP_IBL
    vec3 diffuse_ibl = ibl_diffuse(m, dfg, n);   // the sphere's diffuse share of ibl (the rest is its specular)
#endif
#if USE_TEXTURES && !BUG_FEWTAP_IBL
    if (!ground) {
        // A mapped normal can turn the mirror direction below the sphere's own surface, which
        // blocks that light (the reference's convention): the specular fades as r sinks
        // (Filament's horizon occlusion, (1 + r . n_geo)^2 clamped). 256² against 2048 spp:
        // hammered 0.1109 -> 0.0908 mean FLIP, riveted 0.0510 -> 0.0509; a fade as narrow as
        // the lobe (a step for a mirror) measured 0.0860 and 0.0527.
        float horizon = saturate(1.0 + dot(reflect(-v, n), n_geo));
        ibl = diffuse_ibl + (ibl - diffuse_ibl) * (horizon * horizon);
    }
#endif
#if BOUNCE_MIRROR_DIRECTIONS > 0
    if (!ground && light_specular < 1.0) {   // the bounce rays: a smooth sphere's mirrored sky is closed-form
        ibl = diffuse_ibl + (ibl - diffuse_ibl) * mix(1.0, light_specular, mirrored_sky_share(reflect(-v, n).y));
    }
#endif
#if FLOOR_PARALLAX
    // The floor as the sphere's point sees it, not its centre (floor_parallax.glsl): its
    // diffuse. The specular reads the probe with its own parallax (scene.glsl stage_parallax).
    if (!ground) ibl += ibl_mix(m, dfg, vec3(0.0), vec3(0.0), floor_parallax_irradiance(n) * INV_PI);
#endif
#if NEIGHBOUR_LIGHT
    // The base layer's specular share of the sky (without its diffuse), which the neighbours
    // hide by their share of the lobe rather than by the AO's cosine-weighted share.
    vec3 sky_specular = ibl - diffuse_ibl;
#endif
#if LAYERED_IBL
    if (!ground) ibl = layer_ibl(m, n, v, n_dot_v, ibl, diffuse_ibl, bounce_ray);
#endif
#if USE_AO
#if STAGE == cells && AO_METHOD == analytic && !BUG_FEWTAP_IBL
    if (ground) {
        // The ground: its sphere hides a cosine-weighted share of the diffuse light and the
        // part of the specular lobe it covers (stage_bounce.glsl gives both back as the
        // sphere's own light). The diffuse from the SH9 irradiance (within 2 %), the specular
        // from the ground's table; what is hidden of each is the sky behind the sphere
        // (ao.glsl sky_behind_sphere). A sky brighter on one side darkens the floor on the
        // other: the cosine-weighted average over the whole sky left the studio's floor up to
        // 17 % bright beside the sphere, and the lobe's share of the table's specular (as if
        // the sphere hid the lobe's mean sky) left its reflection 15 % off in front of it.
        if (blocked) {   // the open floor (shadow catcher, see-through spheres) keeps it all
            vec3 diffuse = m.base_color_linear * dfg.z * sh_irradiance(n) * INV_PI;
            HiddenSky hidden = sky_behind_sphere(p, v, m.alpha);
            vec3 specular = ibl - diffuse;
            ibl = max(diffuse - m.base_color_linear * dfg.z * (1.0 - ao) * hidden.diffuse, vec3(0.0))
                + max(specular - hidden.specular * energy_compensation(vec3(DIELECTRIC_F0), e_single), vec3(0.0));
        }
    } else
#endif
    ibl *= ao;
#endif
#if NEIGHBOUR_LIGHT
    if (!ground) {   // the neighbours hide their share of the sky and give their own light there
        NeighbourLight near = neighbour_light(p, n, reflect(-v, n), m.alpha, cell);
        ibl += sky_specular * (1.0 - min(near.lobe_share, 1.0) - ao)
             + ibl_mix(m, dfg, near.specular, near.specular, near.irradiance_over_pi);
    } else if (blocked) {   // the floor: the spheres' light where the AO took the sky away
        ibl += ibl_mix(m, dfg, vec3(0.0), vec3(0.0), floor_sphere_irradiance_over_pi(p, n));
    }
#endif
#if BOUNCE_CACHE && !SPHERE_PLATE_PASS && !GATHER_PLATE
    // The sphere's own light back from its floor (the sphere plate leaves it to the chart,
    // which reads each cell's own cache: the plate's slot stands for several cells).
    if (!ground) ibl += bounce_gather(m, p, n, v, dfg, cell);
#elif BOUNCE_CACHE && GATHER_PLATE
    if (!ground && bounce_ray) ibl += bounce_gather(m, p, n, v, dfg, cell);   // the chart's from the plate
#endif
#if USE_TEXTURES
    ibl *= occlusion;   // the ORM occlusion darkens indirect light only
#endif
    color += ibl;
#endif
#if NUM_DIR_LIGHTS > 0
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i) {
        vec3 l = u_dir_light_direction[i];
        vec3 c = lights_brdf_cos(m, n, v, l, n_dot_v, max(u_dir_light_angular_radius[i], light_spread), e_single,
                                 light_specular, bounce_ray) * u_dir_light_illuminance[i];
#if USE_SHADOWS && (STAGE == cells || SCENE_SDF == nearest_cell)
        // The ground receives every light's shadow (each sphere's share of the disc, shadow.glsl;
        // on the cells stage over the pixel's footprint).
        if (ground && blocked && dot(n, l) > 0.0) {
#if STAGE == cells
            c *= footprint_shadow(p + n_geo * (1e-3 * u_radius), v, pixel_size, l, max(u_dir_light_angular_radius[i], 1e-3));
#else
            c *= soft_shadow(p + n_geo * (1e-3 * u_radius), l, 1.0 / tan(max(u_dir_light_angular_radius[i], 1e-3)));
#endif
        }
#elif USE_SHADOWS
        // Light 0 is the key light; the ground receives its shadow.
        if (i == 0 && ground && blocked && dot(n, l) > 0.0)
            c *= soft_shadow(p + n_geo * (1e-3 * u_radius), l, 1.0 / tan(max(u_dir_light_angular_radius[0], 1e-3)));
#endif
        color += c;
    }
#endif
#if NUM_POINT_LIGHTS > 0
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {
        vec3 to_light = u_point_light_position[i] - p;
        float dist = length(to_light);
        vec3 l = to_light / dist;
        float angle = point_angular_radius(i, dist);
        vec3 c = lights_brdf_cos(m, n, v, l, n_dot_v, max(angle, light_spread), e_single, light_specular, bounce_ray)
               * u_point_light_intensity[i]
               * point_falloff(dist, u_point_light_range[i]);
#if USE_SHADOWS && STAGE == cells
        // The sphere's shadow on its floor, over the pixel's footprint (shadow.glsl).
        if (ground && blocked)
            c *= footprint_point_visibility(p + n_geo * (1e-3 * u_radius), p, v, pixel_size, l, dist, angle);
#elif USE_SHADOWS && SCENE_SDF == nearest_cell
        // The spheres between the ground and the light, each hiding its share of the light's disc.
        if (ground && blocked)
            c *= grid_shadow(p + n_geo * (1e-3 * u_radius), l, max(angle, 1e-4), dist);
#endif
        color += c;
    }
#endif
#if BUG_AO_ON_DIRECT && USE_AO
    color = (color - ibl) * ao + ibl;   // occlusion now also darkens the lights
#endif
#if EMISSION
    if (!ground) color += surface_emission(m, v);
#endif
    return color;
}

vec3 shade_sphere(vec3 p, vec3 n_geo, vec3 v, ivec2 cell, float pixel_size) {
    return shade_point(p, n_geo, v, cell, pixel_size, false, 0.0, 1.0, true, false);
}

// The sphere's light as a few bounce rays sample it: each punctual light's highlight spread as
// if the light were `spread` radians wide (the rays' spacing), and its specular reflection (of
// the lights and of the environment) weighted by `specular`, the share the rays can resolve
// (stage_bounce.glsl). With what its floor gives back (BOUNCE_CACHE, the last draw's): each
// draw of the cache carries one more round trip between the sphere and its floor.
vec3 shade_sphere_for_bounce(vec3 p, vec3 n_geo, vec3 v, ivec2 cell, float pixel_size, float spread, float specular) {
    return shade_point(p, n_geo, v, cell, pixel_size, false, spread, specular, true, true);
}

vec3 shade_ground(vec3 p, vec3 v, float pixel_size) {
    return shade_point(p, vec3(0.0, 1.0, 0.0), v, ivec2(-1), pixel_size, true, 0.0, 1.0, true, false);
}

#if SHADOW_CATCHER || (SEE_THROUGH && STAGE == cells)
// The ground as if no sphere stood on it: what a shadow catcher's transmittance is relative to,
// and a see-through sphere's floor in the share of the light it lets past.
vec3 shade_open_ground(vec3 p, vec3 v, float pixel_size) {
    return shade_point(p, vec3(0.0, 1.0, 0.0), v, ivec2(-1), pixel_size, true, 0.0, 1.0, false, false);
}
#endif

#if SHADOW_CATCHER
// A shadow catcher's pixel, premultiplied: no colour of its own, and the alpha of the light its
// sphere takes from the floor (shadow, occlusion), 1 - L / L_open in luminance; light the
// sphere adds (its bounce) cannot show on a black matte and is left out.
vec4 shadow_catcher(vec3 radiance, float open_luminance) {
    float kept = open_luminance > 0.0 ? luminance(radiance) / open_luminance : 1.0;
    return vec4(0.0, 0.0, 0.0, 1.0 - clamp(kept, 0.0, 1.0));
}
#endif
