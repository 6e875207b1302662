// Textured spheres (glTF conventions): base colour sampled through an sRGB texture; ORM and
// normal maps are linear data; tangent-space normals, +Y up (OpenGL). The bugs below decode
// the linear maps as colour, or read the green channel with the DirectX convention.
uniform sampler2D u_base_color_map;
uniform sampler2D u_orm_map;
uniform sampler2D u_normal_map;

vec3 srgb_eotf(vec3 c) {
    return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(vec3(0.04045), c));
}

struct SurfaceTexels {
    vec3 base_color_linear;
    vec3 orm;              // occlusion, roughness, metallic factors
    vec3 normal;           // world-space shading normal
};

// n: geometric sphere normal; pixel_size: world size of a pixel at the hit (for the mip level).
SurfaceTexels sample_surface(vec3 n, float pixel_size) {
    vec2 uv = vec2(0.5 + atan(n.x, n.z) * (0.5 * INV_PI), acos(clamp(n.y, -1.0, 1.0)) * INV_PI);
    // Texels per world unit along u at the equator: width / (2 pi R); isotropic footprint.
    float texel_world = 2.0 * PI * u_radius / float(textureSize(u_orm_map, 0).x);
    float lod = max(log2(pixel_size / texel_world), 0.0);
    SurfaceTexels s;
    s.base_color_linear = textureLod(u_base_color_map, uv, lod).rgb;
    s.orm = textureLod(u_orm_map, uv, lod).rgb;
#if BUG_ORM_SRGB
    s.orm = srgb_eotf(s.orm);
#endif
    vec3 texel = textureLod(u_normal_map, uv, lod).rgb;
#if BUG_NORMAL_MAP_SRGB
    texel = srgb_eotf(texel);
#endif
    vec3 ts = texel * 2.0 - 1.0;
#if BUG_NORMAL_MAP_GREEN_FLIP
    ts.y = -ts.y;
#endif
    // Tangent along increasing u (around +y), bitangent = N x T points up on the front.
    vec3 t = vec3(n.z, 0.0, -n.x);
    float tl = length(t);
    t = tl > 1e-6 ? t / tl : vec3(1.0, 0.0, 0.0);
    vec3 b = cross(n, t);
    s.normal = normalize(ts.x * t + ts.y * b + ts.z * n);
    return s;
}
