// The cells stage's layout in the image: rows x cols cells of whole pixels from the grid's
// lower-left pixel (sdfpbr/shading/camera.py cell_grid). Read by the chart (scene.glsl) and by
// the display pass (an exposure axis).
uniform ivec2 u_grid;          // (cols, rows)
uniform ivec2 u_cell_size;     // pixels per cell
uniform ivec2 u_grid_origin;   // lower-left pixel of the grid

// The (col, row) a pixel (GL coordinates, y up) lies in, row 0 on top; pixels in the margins
// belong to the nearest cell. Integer division: a float one may be a multiply by the reciprocal
// (NVIDIA's is), which puts a pixel on a cell's first row (33 / 33 = 0.99999994) in the cell below.
// A prepass drawn on a coarser grid, one tile of `tile` texels per cell (tile origin cell *
// tile): the cell its texel belongs to, and the cell pixel position the texel stands for,
// `step` cell pixels apart from the prepass's origin (both uniforms the prepass binds).
vec2 prepass_grid_position(ivec2 texel, ivec2 tile, float step, vec2 origin, out ivec2 cell) {
    cell = texel / tile;   // (col, row from the top), as grid_cell gives the chart
    return origin + 0.5 + vec2(texel - cell * tile) * step;
}

ivec2 grid_cell(vec2 pixel, out ivec2 index) {
    ivec2 from_origin = max(ivec2(floor(pixel)) - u_grid_origin, ivec2(0));   // margins: the nearest cell
    index = min(from_origin / u_cell_size, u_grid - 1);
    return ivec2(index.x, u_grid.y - 1 - index.y);   // GL rows run up
}
