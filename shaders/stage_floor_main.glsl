#include "common.glsl"
#include "loop_guard.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "camera.glsl"
#include "surface_shading.glsl"
#include "background.glsl"

// The cells stage's floor prepass (FLOOR_PREPASS): every cell shows the same floor under the same
// camera, so the part of its light that does not depend on the cell's material (environment,
// lights, the sphere's occlusion and shadows) is shaded once per cell pixel here, and the chart
// reads it back (chart_main.glsl), adding only the light its own sphere bounces onto it.
// One texel per cell pixel: the floor point the pixel-centre ray meets, sphere or not, or
// where it meets no floor the background (the same in every cell, too).
// The prepass spans the cell and the image's margins beyond the grid (the outer cells' pixels
// there see the floor further out): texel (0, 0) is cell pixel u_prepass_origin.
layout(location = 0) out vec4 out_radiance;
uniform vec2 u_prepass_origin;

void floor_prepass_texel() {
    vec2 position = gl_FragCoord.xy + u_prepass_origin;   // the pixel centre, in the cell's frame
    vec3 rd;
    vec3 ro = camera_ray(2.0 * position / u_resolution - 1.0, rd);
    float t = rd.y < 0.0 ? (u_ground_y - ro.y) / rd.y : -1.0;
    if (t <= 0.0) { out_radiance = vec4(background(rd), 0.0); return; }   // no floor: the background
    vec2 footprint = pixel_footprint();
    vec3 p = ro + rd * t;
    float pixel_size = footprint.x + footprint.y * t;
#if SHADOW_CATCHER
    // a: the open floor's luminance, what the chart's shadow catcher divides by
    out_radiance = vec4(shade_ground(p, -rd, pixel_size), luminance(shade_open_ground(p, -rd, pixel_size)));
#else
    out_radiance = vec4(shade_ground(p, -rd, pixel_size), 1.0);
#endif
}

void main() {
    floor_prepass_texel();
    loop_guard();   // whether its loops ran in full (gpu/loop_guard.py)
}
