// The chart's materials: one row of texels per cell in u_cell_materials (cell index
// row * cols + col), written by sdfpbr/shading/material_table.py from each cell's Material:
//   0: base colour (linear), metallic      1: roughness, clearcoat, clearcoat roughness, sheen roughness
//   2: sheen colour, alpha                  3: f0(ior) x specular colour (unclamped), specular
//   4: emission (emissive colour x strength), alpha test (-2 opaque, -1 blend, else the mask's cutoff)
// A program reads only the texels of the lobes it composes in. The ground is uniforms.
uniform sampler2D u_cell_materials;
uniform vec3 u_ground_color;
uniform float u_ground_roughness;

vec4 cell_texel(ivec2 cell, int k) {
    return texelFetch(u_cell_materials, ivec2(k, cell.y * u_grid.x + cell.x), 0);
}

Material ground_material() {
    return make_material(u_ground_color, 0.0, u_ground_roughness);
}

// A sphere's material; n_geo: its geometric normal (the clearcoat's).
Material cell_material(ivec2 cell, vec3 n_geo) {
    vec4 t0 = cell_texel(cell, 0), t1 = cell_texel(cell, 1);
    Material m = make_material(t0.rgb, t0.a, t1.x);
#if CLEARCOAT
    m.clearcoat = t1.y;
    set_clearcoat_roughness(m, t1.z);
    m.clearcoat_normal = n_geo;
#endif
#if SHEEN
    m.sheen_color_linear = cell_texel(cell, 2).rgb;
    m.sheen_perceptual_roughness = max(t1.w, MIN_PERCEPTUAL_ROUGHNESS);
#endif
#if KHR_SPECULAR && !BUG_IOR_IGNORED
    vec4 t3 = cell_texel(cell, 3);
    m.specular_f0 = min(t3.rgb, vec3(1.0));
    m.specular_weight = t3.a;
#endif
#if EMISSION
    m.emission_linear = cell_texel(cell, 4).rgb;
#endif
    return m;
}

#if USE_TEXTURES
// glTF: texture values scale the cell's factors (roughness before its clamp).
void apply_texels(inout Material m, ivec2 cell, SurfaceTexels tx) {
    m.base_color_linear *= tx.base_color_linear;
    m.metallic *= tx.orm.b;   // the factor (cell_material), or the sphere prepass's end
    set_roughness(m, cell_texel(cell, 1).x * tx.orm.g);
#if EMISSION
    m.emission_linear *= tx.emission_linear;
#endif
    // The KHR extensions' maps (glTF: texture x factor; f0 clamped after the colour).
#if CLEARCOAT
    m.clearcoat *= tx.khr.r;
    set_clearcoat_roughness(m, cell_texel(cell, 1).z * tx.khr.g);
    m.clearcoat_normal = tx.coat_normal;
#endif
#if SHEEN
    m.sheen_color_linear *= tx.sheen_color_linear;
    m.sheen_perceptual_roughness = max(cell_texel(cell, 1).w * tx.khr.a, MIN_PERCEPTUAL_ROUGHNESS);
#endif
#if KHR_SPECULAR && !BUG_IOR_IGNORED
    m.specular_f0 = min(cell_texel(cell, 3).rgb * tx.specular_color_linear, vec3(1.0));
    m.specular_weight *= tx.khr.b;
#endif
}
#endif

#if SEE_THROUGH
// glTF alphaMode on a cell's alpha: 1 for opaque; the alpha for blend; for mask, 1 where it
// reaches the cutoff and 0 below it.
float alpha_coverage(ivec2 cell, float alpha) {
    float test = cell_texel(cell, 4).a;
    if (test < -1.5) return 1.0;
    if (test < 0.0) return alpha;
    return alpha >= test ? 1.0 : 0.0;
}

// The share of its pixel the camera sees of a sphere at geometric normal n_geo: the coverage
// of the factor's alpha times the base colour map's.
float sphere_alpha(ivec2 cell, vec3 n_geo, float pixel_size) {
    float alpha = cell_texel(cell, 2).a;
#if USE_TEXTURES
    alpha *= base_alpha(n_geo, pixel_size, cell);
#endif
    return alpha_coverage(cell, alpha);
}
#endif

// The share of the light a cell's sphere stops: the light meets it as the camera does, alpha
// as coverage, so its shadow, occlusion and bounce on the floor come in that share. The
// factor's alpha is the same all over; with a base colour map, the coverage's mean over
// LIGHT_COVERAGE_POINTS points spread evenly over the sphere (a spiral, equal areas), the map
// read at a quarter radius per texel: a mask's holes thin the occlusion and bounce by their
// share, not in their pattern (shadows take the pattern: light_ray_coverage below).
#define LIGHT_COVERAGE_POINTS 16
float light_coverage(ivec2 cell) {
#if SEE_THROUGH && USE_TEXTURES
    float sum = 0.0;
    for (int k = 0; k < LIGHT_COVERAGE_POINTS; ++k) {
        sum += sphere_alpha(cell, spiral_direction(k, LIGHT_COVERAGE_POINTS, -1.0), 0.25 * u_radius);
    }
    return sum / float(LIGHT_COVERAGE_POINTS);
#elif SEE_THROUGH
    return sphere_alpha(cell, vec3(0.0, 1.0, 0.0), u_radius);
#else
    return 1.0;
#endif
}

#if SEE_THROUGH && USE_TEXTURES
#if HAS_BASE_COLOR_MAP
// The share of a footprint `size` wide (world units) at n_geo that stops light: the map's alpha
// filtered over it (blend, opaque). A mask's cutoff is tested as the camera does where the
// footprint is a texel or less; over two texels or more it is the share of the footprint that
// passes, which the filtered alpha is for a map of 0s and 1s (what a mask's map mostly is):
// the cutoff of a filtered value would draw a soft light's blurred pattern sharp.
float light_alpha(ivec2 cell, vec3 n_geo, float size) {
    float cutoff = cell_texel(cell, 4).a, factor = cell_texel(cell, 2).a;
    float map = base_alpha(n_geo, size, cell);
    if (cutoff < 0.0) return alpha_coverage(cell, factor * map);
    float passing = factor >= cutoff ? map : 0.0;
    return mix(factor * map >= cutoff ? 1.0 : 0.0, passing, saturate(layer_lod(u_base_color_map, size)));
}
#endif
#endif

// The share of a light (angular radius `angle`, direction l from p) that the cell's sphere
// (centred at `centre`) stops, where the sphere hides it: the reference's rays towards a light
// pass a see-through sphere with one minus the alpha where they enter it, so with a base
// colour map it is the coverage where the light's central ray enters (or passes closest), the
// map read over the light's cone there: a sharp sun casts the pattern, a soft box a blurred one.
float light_ray_coverage(ivec2 cell, vec3 centre, vec3 p, vec3 l, float angle) {
#if SEE_THROUGH && USE_TEXTURES
#if HAS_BASE_COLOR_MAP
    vec3 oc = p - centre;
    float b = dot(oc, l), h = u_radius * u_radius - (dot(oc, oc) - b * b);
    float along = h >= 0.0 && -b - sqrt(h) > 0.0 ? -b - sqrt(h) : max(-b, 0.0);   // the entry, or the closest approach
    return light_alpha(cell, normalize(oc + l * along), max(2.0 * along * tan(angle), 1e-4 * u_radius));
#else
    return light_coverage(cell);
#endif
#else
    return light_coverage(cell);
#endif
}
