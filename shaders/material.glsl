// The chart's materials: roughness across the columns, metallic down the rows, both ranges
// inclusive of their ends; base colour per row (a neutral grey or a measured metal preset).
uniform vec2 u_roughness_range;
uniform vec2 u_metallic_range;
uniform vec3 u_row_base_color[GRID_ROWS];
uniform vec3 u_ground_color;
uniform float u_ground_roughness;

float grid_fraction(int i, int n) { return n > 1 ? float(i) / float(n - 1) : 0.0; }

float cell_perceptual_roughness(ivec2 cell) {
    return mix(u_roughness_range.x, u_roughness_range.y, grid_fraction(cell.x, u_grid.x));
}

float cell_metallic(ivec2 cell) {
    return mix(u_metallic_range.x, u_metallic_range.y, grid_fraction(cell.y, u_grid.y));
}

Material cell_material(ivec2 cell) {
    if (cell.x < 0) return make_material(u_ground_color, 0.0, u_ground_roughness);
    return make_material(u_row_base_color[cell.y], cell_metallic(cell), cell_perceptual_roughness(cell));
}
