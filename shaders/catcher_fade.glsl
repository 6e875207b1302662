// A cells-stage shadow catcher's alpha fades to nothing towards each of its cell's borders, over
// a band of its own per side (sdfpbr/shading/catcher.py says why and how wide).
// Read by the chart (chart_main.glsl) and the reference (reference_main.glsl) alike.
uniform vec4 u_catcher_band;   // pixels: left, right, bottom, top

// `position`: the pixel in its cell's frame (cell_pixel); beyond the grid (margins) it is 0.
float catcher_fade(vec2 position) {
    vec2 far = vec2(u_cell_size) - position;
    return smoothstep(0.0, u_catcher_band.x, position.x) * smoothstep(0.0, u_catcher_band.y, far.x)
         * smoothstep(0.0, u_catcher_band.z, position.y) * smoothstep(0.0, u_catcher_band.w, far.y);
}
