// The page-colour border round each cell of an opaque cells-stage image, and the image's margins
// beyond the grid (sdfpbr/shading/cells.py cell_border_px: each cell is its own view, so its
// floor would meet the next cell's in a seam). Every cell has the same border: cells stay
// identical. Needs cell_grid.glsl.
uniform int u_cell_border;   // pixels
uniform vec3 u_page_srgb;    // the chart's page colour, as the display writes it

bool on_cell_border(vec2 pixel) {
    ivec2 from_origin = ivec2(floor(pixel)) - u_grid_origin;
    if (any(lessThan(from_origin, ivec2(0))) || any(greaterThanEqual(from_origin, u_grid * u_cell_size))) {
        return true;   // a margin beyond the grid
    }
    // The cell a pixel lies in by a float division, not an integer one, which llvmpipe runs
    // lane by lane (the 1024² display pass: +8 ms with it, +3 ms so). Exact: a pixel's centre is
    // half a pixel from the cells' edges, far beyond a reciprocal's rounding below 4 million px.
    ivec2 local = from_origin - ivec2(floor((vec2(from_origin) + 0.5) / vec2(u_cell_size))) * u_cell_size;
    return any(lessThan(local, ivec2(u_cell_border))) || any(greaterThanEqual(local, u_cell_size - u_cell_border));
}
