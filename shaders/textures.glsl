// Textured spheres (glTF conventions): base colour and emission sampled through sRGB textures; ORM and
// normal maps are linear data; tangent-space normals, +Y up (OpenGL). The bugs below decode
// the linear maps as colour, or read the green channel with the DirectX convention.
// HAS_*_MAP: the maps the spec gives; an absent one leaves the factors (or the geometric
// normal) alone.
#if HAS_BASE_COLOR_MAP
uniform sampler2D u_base_color_map;
#endif
#if HAS_ORM_MAP
uniform sampler2D u_orm_map;
#endif
#if HAS_NORMAL_MAP
uniform sampler2D u_normal_map;
#endif
#if HAS_EMISSIVE_MAP
uniform sampler2D u_emissive_map;
#endif
#if HAS_KHR_MAP
uniform sampler2D u_khr_map;              // clearcoat, clearcoat roughness, specular, sheen roughness
#endif
#if HAS_COAT_NORMAL_MAP
uniform sampler2D u_coat_normal_map;
#endif
#if HAS_SHEEN_COLOR_MAP
uniform sampler2D u_sheen_color_map;
#endif
#if HAS_SPECULAR_COLOR_MAP
uniform sampler2D u_specular_color_map;
#endif

vec3 srgb_eotf(vec3 c) {
    return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(vec3(0.04045), c));
}

struct SurfaceTexels {
    vec3 base_color_linear;
    vec3 orm;              // occlusion, roughness, metallic factors
    vec3 normal;           // world-space shading normal
    vec3 emission_linear;  // scales the emissive factor
    float alpha;           // the base colour map's alpha (scales the factor's)
    vec4 khr;              // scale clearcoat, clearcoat roughness, specular, sheen roughness
    vec3 coat_normal;      // world-space clearcoat normal
    vec3 sheen_color_linear;      // scales the sheen colour
    vec3 specular_color_linear;   // scales the specular colour
};

// A map's texel at the sphere's (u, v), in the cell's layer, at the pixel's level of detail.
#define SAMPLE_MAP(map, uv, cell, pixel_size) textureLod(map, layer_uv(uv, cell, textureSize(map, 0).y), layer_lod(map, pixel_size))

// A tangent-space normal map texel (0..1) on the sphere at geometric normal n: tangent along
// increasing u (around +y), bitangent = N x T (up on the front).
vec3 tangent_normal(vec3 texel, vec3 n) {
    vec3 ts = texel * 2.0 - 1.0;
#if BUG_NORMAL_MAP_GREEN_FLIP
    ts.y = -ts.y;
#endif
    vec3 t = vec3(n.z, 0.0, -n.x);
    float tl = length(t);
    t = tl > 1e-6 ? t / tl : vec3(1.0, 0.0, 0.0);
    vec3 b = cross(n, t);
    return normalize(ts.x * t + ts.y * b + ts.z * n);
}

// Mip level for a map whose width spans the equator (2 pi R): texels per world unit along
// u; isotropic footprint. pixel_size: world size of a pixel at the hit.
float map_lod(int map_width, float pixel_size) {
    float texel_world = 2.0 * PI * u_radius / float(map_width);
    return max(log2(pixel_size / texel_world), 0.0);
}

// u_map_layers > 1: each map holds that many sphere maps stacked top to bottom, cell k's in
// layer k (a glTF asset's materials); v is kept half a texel inside its layer so filtering
// reads no neighbour at level 0 (coarser levels blur across the layers' seams at the poles).
uniform int u_map_layers;

vec2 layer_uv(vec2 uv, ivec2 cell, int map_height) {
    if (u_map_layers <= 1) return uv;
    float h = float(map_height) / float(u_map_layers);
    float v = clamp(uv.y, 0.5 / h, 1.0 - 0.5 / h);
    return vec2(uv.x, (float(cell.y * u_grid.x + cell.x) + v) / float(u_map_layers));
}

// Mip level for a layer of the map, whose width spans the equator (2 pi R).
float layer_lod(sampler2D map, float pixel_size) {
    return map_lod(textureSize(map, 0).x, pixel_size);
}

// The sphere's (u, v) at geometric normal n: u once around +y, v from the top pole down.
vec2 sphere_uv(vec3 n) {
    return vec2(0.5 + atan(n.x, n.z) * (0.5 * INV_PI), acos(clamp(n.y, -1.0, 1.0)) * INV_PI);
}

// The base colour map's alpha alone (1 without the map): what a see-through sphere tests first.
float base_alpha(vec3 n, float pixel_size, ivec2 cell) {
#if HAS_BASE_COLOR_MAP
    return SAMPLE_MAP(u_base_color_map, sphere_uv(n), cell, pixel_size).a;
#else
    return 1.0;
#endif
}

// n: geometric sphere normal; cell: whose layer (u_map_layers > 1).
SurfaceTexels sample_surface(vec3 n, float pixel_size, ivec2 cell) {
    vec2 uv = sphere_uv(n);
    SurfaceTexels s = SurfaceTexels(vec3(1.0), vec3(1.0), n, vec3(1.0), 1.0, vec4(1.0), n, vec3(1.0), vec3(1.0));
#if HAS_BASE_COLOR_MAP
    vec4 base = SAMPLE_MAP(u_base_color_map, uv, cell, pixel_size);
    s.base_color_linear = base.rgb;
    s.alpha = base.a;
#endif
#if HAS_EMISSIVE_MAP
    s.emission_linear = SAMPLE_MAP(u_emissive_map, uv, cell, pixel_size).rgb;
#endif
#if HAS_ORM_MAP
    s.orm = SAMPLE_MAP(u_orm_map, uv, cell, pixel_size).rgb;
#if BUG_ORM_SRGB
    s.orm = srgb_eotf(s.orm);
#endif
#endif
#if HAS_NORMAL_MAP
    vec3 texel = SAMPLE_MAP(u_normal_map, uv, cell, pixel_size).rgb;
#if BUG_NORMAL_MAP_SRGB
    texel = srgb_eotf(texel);
#endif
    s.normal = tangent_normal(texel, n);
#endif
#if HAS_KHR_MAP
    s.khr = SAMPLE_MAP(u_khr_map, uv, cell, pixel_size);
#endif
#if HAS_COAT_NORMAL_MAP
    s.coat_normal = tangent_normal(SAMPLE_MAP(u_coat_normal_map, uv, cell, pixel_size).rgb, n);
#endif
#if HAS_SHEEN_COLOR_MAP
    s.sheen_color_linear = SAMPLE_MAP(u_sheen_color_map, uv, cell, pixel_size).rgb;
#endif
#if HAS_SPECULAR_COLOR_MAP
    s.specular_color_linear = SAMPLE_MAP(u_specular_color_map, uv, cell, pixel_size).rgb;
#endif
    return s;
}
