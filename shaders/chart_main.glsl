#include "common.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "camera.glsl"
#include "ggx.glsl"
#include "visibility.glsl"
#include "brdf.glsl"
#include "dfg.glsl"
#include "material.glsl"
#if USE_TEXTURES
#include "textures.glsl"
#endif
#include "env.glsl"
#include "lights.glsl"
#if USE_IBL && BUG_FEWTAP_IBL
#include "ibl_fewtap.glsl"
#elif USE_IBL
#include "ibl.glsl"
#endif
#if GROUND_IBL
#include "ground_ibl.glsl"
#endif
#if USE_AO
#include "ao.glsl"
#endif
#if USE_SHADOWS
#include "shadow.glsl"
#endif
#if INTERSECT == analytic
#include "intersect.glsl"
#else
#include "normal.glsl"
#include "march.glsl"
#endif
#include "shade.glsl"
#if STAGE == cells && HAS_GROUND && USE_AO
#include "stage_bounce.glsl"   // the light the AO takes from the floor's sky, given back by the sphere
#endif

// Chart program: one fullscreen triangle per tile; each pixel averages SPP stratified rays.
// Outputs linear HDR radiance + coverage, and the AOVs of the pixel-centre ray.
layout(location = 0) out vec4 out_radiance;      // rgb radiance, a coverage
layout(location = 1) out vec4 out_normal_depth;  // world normal, distance along the ray
layout(location = 2) out vec4 out_cell;          // col, row, NdotV, 0 (-1 for background)
uniform vec2 u_tile_origin;                      // pixel offset of this tile in the image
uniform int u_spp;

vec3 background(vec3 rd) {
#if TRANSPARENT
    return vec3(0.0);   // premultiplied: misses add no colour, only less coverage
#endif
    vec3 c = env_radiance(rd);
#if NUM_DIR_LIGHTS > 0
    c += light_discs(rd);
#endif
    return c;
}

// R2 low-discrepancy offsets (Roberts 2018); sample 0 is the pixel centre.
vec2 sample_offset(int i) {
    return fract(vec2(0.5) + float(i) * vec2(0.7548776662, 0.5698402909));
}

void main() {
    vec2 pixel = gl_FragCoord.xy - 0.5 + u_tile_origin;
#if STAGE == cells
    pixel = cell_pixel(pixel, g_cell);   // the camera then sees this cell's own scene
#endif
    vec2 footprint = pixel_footprint();
    vec4 sum = vec4(0.0);
    for (int s = 0; s < u_spp; ++s) {
        vec2 ndc = 2.0 * (pixel + sample_offset(s)) / u_resolution - 1.0;
        vec3 rd;
        vec3 ro = camera_ray(ndc, rd);
        Hit hit = intersect_scene(ro, rd, footprint);
        if (hit.t < 0.0) {
            sum += vec4(background(rd), 0.0);
        } else {
            vec3 p = ro + rd * hit.t;
            float pixel_size = footprint.x + footprint.y * hit.t;
            vec3 radiance = shade_surface(p, hit.normal, -rd, hit.cell, pixel_size);
#if STAGE == cells && HAS_GROUND && USE_AO
            if (hit.cell.x < 0) radiance += sphere_bounce(p, -rd, g_cell, pixel_size);
#endif
            sum += vec4(radiance, 1.0);
        }
        if (s == 0) {
            out_normal_depth = hit.t < 0.0 ? vec4(0.0, 0.0, 0.0, 1.0 / 0.0) : vec4(hit.normal, hit.t);
            float n_dot_v = hit.t < 0.0 ? -1.0 : dot(hit.normal, -rd);
            out_cell = hit.t < 0.0 ? vec4(-1.0, -1.0, -1.0, 0.0) : vec4(vec2(hit.cell), n_dot_v, 0.0);
        }
    }
    out_radiance = sum / float(u_spp);
#if HALF_RADIANCE
    // A half-float target holds at most 65504; some drivers turn larger values into Inf.
    out_radiance = min(out_radiance, vec4(65504.0));
#endif
}
