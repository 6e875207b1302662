// The cells stage's layout in the image: rows x cols cells of whole pixels from the grid's
// lower-left pixel (sdfpbr/shading/camera.py cell_grid). Read by the chart (scene.glsl) and by
// the display pass (an exposure axis).
uniform ivec2 u_grid;          // (cols, rows)
uniform ivec2 u_cell_size;     // pixels per cell
uniform ivec2 u_grid_origin;   // lower-left pixel of the grid

// The (col, row) a pixel (GL coordinates, y up) lies in, row 0 on top; pixels in the margins
// belong to the nearest cell.
ivec2 grid_cell(vec2 pixel, out ivec2 index) {
    index = clamp(ivec2(floor(floor(pixel - vec2(u_grid_origin)) / vec2(u_cell_size))), ivec2(0), u_grid - 1);
    return ivec2(index.x, u_grid.y - 1 - index.y);   // GL rows run up
}
