#include "common.glsl"
#include "tonemap.glsl"
#include "encode.glsl"
#if EXPOSURE_AXIS != none || CELL_BORDER
#include "cell_grid.glsl"
#endif
#if CELL_BORDER
#include "cell_border.glsl"
#endif

// Display program: linear HDR -> exposure -> tone map -> OETF, straight alpha out.
uniform sampler2D u_radiance;
uniform float u_exposure_scale;   // 2^EV
#if BACKDROP
uniform vec3 u_backdrop_srgb;     // the page colour under the render's alpha
#endif
layout(location = 0) out vec4 out_color;
#if EXPOSURE_AXIS != none || CELL_BORDER
uniform vec2 u_display_origin;    // this pass's pixel (0, 0) in the image (tiles)
#endif
#if EXPOSURE_AXIS != none
// Exposure on an axis: each cell's EV (relative to u_exposure_scale's) by its column (x) or row (y).
uniform float u_axis_ev[64];       // MAX_GRID entries (spec/presets.py)
#endif

void main() {
    vec4 hdr = texelFetch(u_radiance, ivec2(gl_FragCoord.xy), 0);
#if TRANSPARENT
    vec3 radiance = hdr.a > 0.0 ? hdr.rgb / hdr.a : vec3(0.0);   // un-premultiply
    float alpha = hdr.a;
#else
    vec3 radiance = hdr.rgb;
    float alpha = 1.0;
#endif
    vec3 x = radiance * u_exposure_scale;
#if EXPOSURE_AXIS != none
    ivec2 index;
    ivec2 cell = grid_cell(gl_FragCoord.xy - 0.5 + u_display_origin, index);
#if EXPOSURE_AXIS == x
    x *= exp2(u_axis_ev[cell.x]);
#else
    x *= exp2(u_axis_ev[cell.y]);
#endif
#endif
#if BUG_DOUBLE_TONEMAP
    x = x / (1.0 + x);   // Reinhard, then the chosen tone map again
#endif
    vec3 display = tonemap(x);
#if BUG_NO_SRGB_ENCODE
    display = saturate(display);
#elif BUG_GAMMA_POW
    display = pow(saturate(display), vec3(1.0 / 2.2));
#elif BUG_DOUBLE_GAMMA
    display = srgb_oetf(srgb_oetf(display));
#else
    display = srgb_oetf(display);
#endif
#if BACKDROP
    out_color = vec4(mix(u_backdrop_srgb, display, alpha), 1.0);   // as a page composites straight alpha
#else
    out_color = vec4(display, alpha);
#endif
#if CELL_BORDER
    if (on_cell_border(gl_FragCoord.xy - 0.5 + u_display_origin)) {
        out_color = vec4(u_page_srgb, 1.0);
    }
#endif
}
