#include "common.glsl"
#include "loop_guard.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "camera.glsl"
#include "surface_shading.glsl"
#include "stage_bounce.glsl"

// The cells stage's bounce prepass (BOUNCE_PREPASS): the light each cell's sphere bounces onto its
// own floor (stage_bounce.glsl: BOUNCE_RAYS shadings of the sphere per floor point) varies
// over the scale of the sphere, not of a pixel, so it is shaded on a grid u_bounce_step cell
// pixels apart and the chart interpolates it (chart_main.glsl). One tile of u_bounce_tile
// texels per cell (the cell's material), spanning the floor prepass's extent: tile texel (i, j)
// is the pixel centre u_prepass_origin + 0.5 + (i, j) u_bounce_step of that cell's frame.
layout(location = 0) out vec4 out_bounce;
uniform vec2 u_prepass_origin;
uniform ivec2 u_bounce_tile;
uniform float u_bounce_step;

void bounce_prepass_texel() {
    vec2 position = prepass_grid_position(ivec2(gl_FragCoord.xy), u_bounce_tile, u_bounce_step, u_prepass_origin,
                                          g_cell);
    vec3 rd;
    vec3 ro = camera_ray(2.0 * position / u_resolution - 1.0, rd);
    float t = rd.y < 0.0 ? (u_ground_y - ro.y) / rd.y : -1.0;
    if (t <= 0.0) { out_bounce = vec4(0.0); return; }   // no floor there: nothing to light
    vec2 footprint = pixel_footprint();
    out_bounce = vec4(sphere_bounce(ro + rd * t, -rd, g_cell, footprint.x + footprint.y * t), 1.0);
}

void main() {
    bounce_prepass_texel();
    loop_guard();   // whether its loops ran in full (gpu/loop_guard.py)
}
