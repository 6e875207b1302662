// The edge pass's triangles (chart_main.glsl, EDGE_PIXELS only): a ring round each sphere's
// silhouette, in GL pixels (shading/camera.py silhouette_ring). On the cells stage the ring is
// in a cell's frame and drawn once per cell (an instance each, the cell's offset added); on the
// shared stage the rings of every sphere are in the image's frame, drawn once.
#if STAGE == cells
#include "cell_grid.glsl"
#endif
in vec2 in_ring;
uniform vec2 u_tile_origin;     // the tile's pixel offset in the image
uniform ivec2 u_ring_viewport;  // the tile's size in pixels

void main() {
    vec2 pixel = in_ring;
#if STAGE == cells
    pixel += vec2(u_grid_origin + ivec2(gl_InstanceID % u_grid.x, gl_InstanceID / u_grid.x) * u_cell_size);
#endif
    gl_Position = vec4(2.0 * (pixel - u_tile_origin) / vec2(u_ring_viewport) - 1.0, 0.0, 1.0);
}
