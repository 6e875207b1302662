#include "common.glsl"
#include "hit.glsl"
#include "scene.glsl"
#include "camera.glsl"
#include "intersect.glsl"
#include "reference_intersect.glsl"

// The AOVs of the pixel-centre ray, laid out as the chart program writes them.
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) uniform writeonly image2D u_normal_depth;   // world normal, distance
layout(rgba32f, binding = 1) uniform writeonly image2D u_cell;           // col, row, NdotV (-1: miss)
uniform ivec2 u_tile_origin;
uniform ivec2 u_tile_size;

void main() {
    ivec2 local_id = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(local_id, u_tile_size))) return;
    ivec2 pixel = u_tile_origin + local_id;
    vec2 base = vec2(pixel);
#if STAGE == cells
    base = cell_pixel(base, g_cell);   // as chart_main: the pixel in its cell's frame
#endif
    vec2 ndc = 2.0 * (base + 0.5) / u_resolution - 1.0;
    vec3 rd;
    vec3 ro = camera_ray(ndc, rd);
    Hit hit = trace_scene(ro, rd, 1e30, SKIP_NONE);
    bool miss = hit.t < 0.0;
    imageStore(u_normal_depth, pixel, miss ? vec4(0.0, 0.0, 0.0, 1.0 / 0.0) : vec4(hit.normal, hit.t));
    imageStore(u_cell, pixel, miss ? vec4(-1.0, -1.0, -1.0, 0.0)
                                  : vec4(vec2(hit.cell), dot(hit.normal, -rd), hit.cell.x >= 0 ? 1.0 : 0.0));
}
