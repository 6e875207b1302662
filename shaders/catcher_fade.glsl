// A cells-stage shadow catcher's alpha fades to nothing over a band along each cell's border,
// u_catcher_band pixels wide across and down (sdfpbr/shading/cells.py CATCHER_BAND says why
// and how wide).
// Read by the chart (chart_main.glsl) and the reference (reference_main.glsl) alike.
uniform vec2 u_catcher_band;

// `position`: the pixel in its cell's frame (cell_pixel); beyond the grid (margins) it is 0.
float catcher_fade(vec2 position) {
    vec2 fade = smoothstep(vec2(0.0), u_catcher_band, position)
              * smoothstep(vec2(0.0), u_catcher_band, vec2(u_cell_size) - position);
    return fade.x * fade.y;
}
