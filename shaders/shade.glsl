#include "bounce_split.glsl"
#include "lobe_read.glsl"

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
// share of it the rays resolve; the base under it keeps its own split. The floor's lobe samples
// take the same share: a smooth coat's highlight, spread over their spacing, lit a bright
// blotch in front of each rough coated sphere of the lobes scene (0.0257 mean FLIP, 0.0231
// with the share).
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


#if SPHERE_PREPASS_PASS
float g_prepass_metallic = 0.0;   // the sphere prepass shades each slot's sphere at metallic 0 and 1
#endif

// A point as shade_point shades it: its material (the maps applied on a sphere), its normals,
// the view, and the DFG LUT's entry there.
struct Surface {
    vec3 p;
    vec3 n_geo;          // the geometry's normal
    vec3 n;              // the shading normal (a normal map's)
    vec3 v;
    ivec2 cell;
    float pixel_size;    // the world size of a pixel at p (texture level of detail)
    Material m;
    float n_dot_v;
    vec3 dfg;
    float e_single;
#if USE_TEXTURES
    float occlusion;     // the ORM map's (1 on the ground)
#endif
};

Surface surface_at(vec3 p, vec3 n_geo, vec3 v, ivec2 cell, float pixel_size, bool ground) {
#if STAGE_PROBE
    g_shading_point = p;   // for the probe's parallax correction
#endif
    Surface s;
    s.p = p;
    s.n_geo = n_geo;
    s.v = v;
    s.cell = cell;
    s.pixel_size = pixel_size;
    s.m = ground ? ground_material() : cell_material(cell, n_geo);
#if SPHERE_PREPASS_PASS
    if (!ground) s.m.metallic = g_prepass_metallic;
#endif
    s.n = n_geo;
#if USE_TEXTURES
    s.occlusion = 1.0;
    if (!ground) {   // glTF: texture values scale the cell's factors
        SurfaceTexels tx = sample_surface(n_geo, pixel_size, cell);
        apply_texels(s.m, cell, tx);
        s.occlusion = tx.orm.r;
        s.n = tx.normal;
    }
#endif
#if BUG_UNCLAMPED_NDOTV
    s.n_dot_v = dot(s.n, v);
#else
    s.n_dot_v = max(dot(s.n, v), MIN_N_DOT_V);
#endif
    s.dfg = dfg_lookup(s.n_dot_v, s.m.perceptual_roughness);
    s.e_single = s.dfg.x + s.dfg.y;
    return s;
}

#if USE_IBL
// The environment's light on the point as the IBL method integrates it: the spheres per pixel
// (sampled) or by the split sum, the ground from its table.
vec3 environment_ibl(Surface s, bool ground) {
#if IBL_METHOD == sampled && !BUG_FEWTAP_IBL
    return !ground ? shade_ibl_sampled(s.m, s.n, s.v, s.n_dot_v, s.dfg) : ground_ibl_term(s.m, s.n, s.v, s.n_dot_v, s.dfg);
#else
    return !ground ? shade_ibl(s.m, s.n, s.v, s.n_dot_v, s.dfg) : ground_ibl_term(s.m, s.n, s.v, s.n_dot_v, s.dfg);
#endif
}

#if !BUG_FEWTAP_IBL
// A sphere's environment light as its surface and its floor shape it; diffuse_ibl is its
// diffuse share. `light_specular` < 1: a bounce ray's, whose smooth sphere's mirrored sky the
// floor gets in closed form (stage_bounce.glsl).
vec3 sphere_environment(Surface s, vec3 ibl, vec3 diffuse_ibl, float light_specular) {
#if USE_TEXTURES
    // A mapped normal can turn the mirror direction below the sphere's own surface, which
    // blocks that light (the reference's convention): the specular fades as r sinks
    // (Filament's horizon occlusion, (1 + r . n_geo)^2 clamped). 256² against 2048 spp:
    // hammered 0.1109 -> 0.0908 mean FLIP, riveted 0.0510 -> 0.0509; a fade as narrow as
    // the lobe (a step for a mirror) measured 0.0860 and 0.0527.
    float horizon = saturate(1.0 + dot(reflect(-s.v, s.n), s.n_geo));
    ibl = diffuse_ibl + (ibl - diffuse_ibl) * (horizon * horizon);
#endif
#if BOUNCE_MIRROR_DIRECTIONS > 0
    if (light_specular < 1.0 && !floor_lobe_reads())
        ibl = diffuse_ibl + (ibl - diffuse_ibl) * mix(1.0, light_specular, mirrored_sky_share(reflect(-s.v, s.n).y));
#endif
#if FLOOR_PARALLAX
    // The floor as the sphere's point sees it, not its centre (floor_parallax.glsl): its
    // diffuse. The specular reads the probe with its own parallax (scene.glsl stage_parallax).
    ibl += ibl_mix(s.m, s.dfg, vec3(0.0), vec3(0.0), floor_parallax_irradiance(s.n) * INV_PI);
#endif
    return ibl;
}
#endif

#if USE_AO
// The environment light the stage leaves the point: ao, the cosine-weighted share of its sky
// it sees. `blocked` false: the open floor (shadow catcher, see-through spheres) keeps it all.
vec3 occluded_environment(Surface s, vec3 ibl, float ao, bool ground, bool blocked) {
#if STAGE == cells && AO_METHOD == analytic && !BUG_FEWTAP_IBL
    if (ground) {
        // The ground: its sphere hides a cosine-weighted share of the diffuse light and the
        // part of the specular lobe it covers (stage_bounce.glsl gives both back as the
        // sphere's own light). The diffuse from the floor's exact irradiance, the specular
        // from the ground's table; what is hidden of each is the sky behind the sphere
        // (ao.glsl sky_behind_sphere). A sky brighter on one side darkens the floor on the
        // other: the cosine-weighted average over the whole sky left the studio's floor up to
        // 17 % bright beside the sphere, and the lobe's share of the table's specular (as if
        // the sphere hid the lobe's mean sky) left its reflection 15 % off in front of it.
        if (blocked) {
            vec3 diffuse = s.m.base_color_linear * s.dfg.z * u_floor_irradiance_over_pi;
            HiddenSky hidden = sky_behind_sphere(s.p, s.v, s.m.alpha);
            vec3 specular = ibl - diffuse;
            ibl = max(diffuse - s.m.base_color_linear * s.dfg.z * (1.0 - ao) * hidden.diffuse, vec3(0.0))
                + max(specular - hidden.specular * energy_compensation(vec3(DIELECTRIC_F0), s.e_single), vec3(0.0));
        }
        return ibl;
    }
#endif
    return ibl * ao;
}
#endif

#if NEIGHBOUR_LIGHT
// The shared stage: a sphere's neighbours hide their share of its sky's specular (sky_specular,
// which they hide by their share of the lobe rather than by the AO's cosine-weighted share) and
// give their own light there; the floor gets the spheres' light where the AO took the sky away.
vec3 neighbours_environment(Surface s, vec3 ibl, vec3 sky_specular, float ao, bool ground, bool blocked) {
    if (!ground) {
        NeighbourLight near = neighbour_light(s.p, s.n, reflect(-s.v, s.n), s.m.alpha, s.cell);
        ibl += sky_specular * (1.0 - min(near.lobe_share, 1.0) - ao)
             + ibl_mix(s.m, s.dfg, near.specular, near.specular, near.irradiance_over_pi);
    } else if (blocked) {
        ibl += ibl_mix(s.m, s.dfg, vec3(0.0), vec3(0.0), floor_sphere_irradiance_over_pi(s.p, s.n));
    }
    return ibl;
}
#endif

// The indirect light leaving the point: the environment as the stage lets it reach the point,
// its neighbours' and (cells stage) its own floor's light. See shade_point for the flags.
vec3 indirect_light(Surface s, float sky_visibility, bool ground, float light_specular, bool blocked, bool bounce_ray) {
    vec3 ibl = environment_ibl(s, ground);
#if !BUG_FEWTAP_IBL
    vec3 diffuse_ibl = ibl_diffuse(s.m, s.dfg, s.n);   // the sphere's diffuse share of ibl (the rest is its specular)
    if (!ground) ibl = sphere_environment(s, ibl, diffuse_ibl, light_specular);
#endif
#if NEIGHBOUR_LIGHT
    vec3 sky_specular = ibl - diffuse_ibl;
#endif
#if LAYERED_IBL
    if (!ground) ibl = layer_ibl(s.m, s.n, s.v, s.n_dot_v, ibl, diffuse_ibl, bounce_ray);
#endif
#if USE_AO
    ibl = occluded_environment(s, ibl, sky_visibility, ground, blocked);
#endif
#if NEIGHBOUR_LIGHT
    ibl = neighbours_environment(s, ibl, sky_specular, sky_visibility, ground, blocked);
#endif
#if BOUNCE_CACHE && !SPHERE_PREPASS_PASS && !GATHER_PREPASS
    // The sphere's own light back from its floor (the sphere prepass leaves it to the chart,
    // which reads each cell's own cache: the prepass's slot stands for several cells).
    if (!ground) ibl += bounce_gather(s.m, s.p, s.n, s.v, s.dfg, s.cell,
                                     bounce_ray ? BOUNCE_RAY_GATHER_SAMPLES : BOUNCE_GATHER_SAMPLES);
#elif BOUNCE_CACHE && GATHER_PREPASS
    // The chart's from the prepass.
    if (!ground && bounce_ray) ibl += bounce_gather(s.m, s.p, s.n, s.v, s.dfg, s.cell, BOUNCE_RAY_GATHER_SAMPLES);
#endif
#if USE_TEXTURES
    ibl *= s.occlusion;   // the ORM occlusion darkens indirect light only
#endif
    return ibl;
}
#endif

// The share of its pixel's width one shading sample stands for: 1 / n where the pixel averages
// n x n points (SPHERE_SAMPLES), 1 / sqrt(spp) under supersampling (chart_main.glsl). The
// plan's RenderPlan.glint_share states the same rule for the float64 checks.
float g_glint_share = 1.0;

#if NUM_DIR_LIGHTS > 0 || NUM_POINT_LIGHTS > 0
// The angular radius a light is shaded with. On a sphere, a light's highlight is spread over
// what the pixel sees of it: across one pixel the normal turns by pixel_size / R and the
// reflected direction by twice that, a box 2 pixel_size / R wide, which a disc of radius
// 2 / sqrt(3) pixel_size / R matches in variance. A glint smaller than a pixel (a 0.8-degree
// sun in a mirror sphere, 128x128) was else met or missed by the pixel's centre: the mirror's
// upper half read 15 % dark against the reference's pixel-averaged one. The disc's energy is
// the light's (ggx.glsl d_ggx_disc), so only where the glint lands spreads. Where a pixel
// averages several points, each spreads over its own share (g_glint_share): spread over the
// whole pixel too, the default chart's small spheres read 0.0234 mean FLIP at 128², 0.0229
// before. The flat floor's normal does not turn.
#define GLINT_SPREAD 1.1547   // 2 / sqrt(3)
float shaded_light_angle(Surface s, bool ground, float angle, float light_spread) {
    float glint = ground ? 0.0 : GLINT_SPREAD * g_glint_share * s.pixel_size / u_radius;
    return max(sqrt(angle * angle + glint * glint), light_spread);
}
#endif

#if NUM_DIR_LIGHTS > 0
// The directional lights' light, added to color one by one; on the ground `blocked` by the
// spheres' shadows.
void add_directional_lights(Surface s, bool ground, float light_spread, float light_specular, bool blocked,
                            bool bounce_ray, inout vec3 color) {
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i) {
        vec3 l = u_dir_light_direction[i];
        vec3 c = lights_brdf_cos(s.m, s.n, s.v, l, s.n_dot_v,
                                 shaded_light_angle(s, ground, u_dir_light_angular_radius[i], light_spread),
                                 s.e_single, light_specular, bounce_ray) * u_dir_light_illuminance[i];
#if USE_SHADOWS && (STAGE == cells || SCENE_SDF == nearest_cell)
        // The ground receives every light's shadow (each sphere's share of the disc, shadow.glsl;
        // on the cells stage over the pixel's footprint).
        if (ground && blocked && dot(s.n, l) > 0.0) {
#if STAGE == cells
            c *= footprint_shadow(s.p + s.n_geo * (1e-3 * u_radius), s.v, s.pixel_size, l,
                                  max(u_dir_light_angular_radius[i], 1e-3));
#else
            c *= soft_shadow(s.p + s.n_geo * (1e-3 * u_radius), l, 1.0 / tan(max(u_dir_light_angular_radius[i], 1e-3)));
#endif
        }
#elif USE_SHADOWS
        // Light 0 is the key light; the ground receives its shadow.
        if (i == 0 && ground && blocked && dot(s.n, l) > 0.0)
            c *= soft_shadow(s.p + s.n_geo * (1e-3 * u_radius), l, 1.0 / tan(max(u_dir_light_angular_radius[0], 1e-3)));
#endif
        color += c;
    }
}
#endif

#if NUM_POINT_LIGHTS > 0
// The point lights' light, added to color one by one; on the ground `blocked` by the spheres.
void add_point_lights(Surface s, bool ground, float light_spread, float light_specular, bool blocked,
                      bool bounce_ray, inout vec3 color) {
    for (int i = 0; i < NUM_POINT_LIGHTS; ++i) {
        vec3 to_light = u_point_light_position[i] - s.p;
        float dist = length(to_light);
        vec3 l = to_light / dist;
        float angle = point_angular_radius(i, dist);
        vec3 c = lights_brdf_cos(s.m, s.n, s.v, l, s.n_dot_v, shaded_light_angle(s, ground, angle, light_spread),
                                 s.e_single, light_specular, bounce_ray)
               * u_point_light_intensity[i]
               * point_falloff(dist, u_point_light_range[i]);
#if USE_SHADOWS && STAGE == cells
        // The sphere's shadow on its floor, over the pixel's footprint (shadow.glsl).
        if (ground && blocked)
            c *= footprint_point_visibility(s.p + s.n_geo * (1e-3 * u_radius), s.p, s.v, s.pixel_size, l, dist, angle);
#elif USE_SHADOWS && SCENE_SDF == nearest_cell
        // The spheres between the ground and the light, each hiding its share of the light's disc.
        if (ground && blocked)
            c *= grid_shadow(s.p + s.n_geo * (1e-3 * u_radius), l, max(angle, 1e-4), dist);
#endif
        color += c;
    }
}
#endif

// Radiance leaving a surface point towards the camera: its indirect light (the environment,
// occluded by AO) plus the punctual lights (shadowed on the ground where shadows are composed
// in). Each physical term is a function above, its variants chosen by the plan's options.
// `ground` is a literal at every call (shade_sphere, shade_ground below): after inlining, each
// keeps only its own code (a runtime test let llvmpipe run the ground's occlusion for every
// sphere point too). `blocked` (a literal too): the ground's light as its sphere blocks it
// (occlusion, shadows); false gives the open floor a shadow catcher divides by.
// `light_spread`, `light_specular`: the bounce rays' (shade_sphere_for_bounce), 0 and 1
// (literals) elsewhere; `bounce_ray` (a literal) true there.
vec3 shade_point(vec3 p, vec3 n_geo, vec3 v, ivec2 cell, float pixel_size, bool ground, float light_spread,
                 float light_specular, bool blocked, bool bounce_ray) {
    Surface s = surface_at(p, n_geo, v, cell, pixel_size, ground);
    vec3 color = vec3(0.0);
    // The share of the point's sky the stage leaves it (ambient occlusion; 1 without it).
#if USE_AO
    float sky_visibility = ground && !blocked ? 1.0 : ambient_occlusion(p, n_geo, cell);
#else
    float sky_visibility = 1.0;
#endif
#if USE_IBL
    vec3 ibl = indirect_light(s, sky_visibility, ground, light_specular, blocked, bounce_ray);
    color += ibl;
#endif
#if NUM_DIR_LIGHTS > 0
    add_directional_lights(s, ground, light_spread, light_specular, blocked, bounce_ray, color);
#endif
#if NUM_POINT_LIGHTS > 0
    add_point_lights(s, ground, light_spread, light_specular, blocked, bounce_ray, color);
#endif
#if BUG_AO_ON_DIRECT && USE_AO
    color = (color - ibl) * sky_visibility + ibl;   // occlusion now also darkens the lights
#endif
#if EMISSION
    if (!ground) color += surface_emission(s.m, v);
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
