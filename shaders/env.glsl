// The procedural HDR environment: the single definition used for the background, the IBL
// bake and the reference renderer. Radiance in linear units, direction world-space, y up.
uniform float u_env_intensity;
#if ENV == file
uniform sampler2D u_env_map;   // equirectangular, linear float RGB, row 0 at the zenith
#endif
#if ENV == sky
uniform vec3 u_sun_direction;
#endif

// A soft-edged cap of angular radius `radius` around axis (a studio softbox seen from afar).
float soft_cap(vec3 d, vec3 axis, float radius, float softness) {
    float ang = acos(clamp(dot(d, axis), -1.0, 1.0));
    return 1.0 - smoothstep(radius - softness, radius + softness, ang);
}

vec3 env_radiance(vec3 d) {
#if ENV == uniform
    return vec3(u_env_intensity);
#elif ENV == black
    return vec3(0.0);
#elif ENV == studio
    float up = saturate(d.y);
    vec3 sky = mix(vec3(0.30, 0.31, 0.34), vec3(0.10, 0.11, 0.13), sqrt(up));
    vec3 floor_color = vec3(0.06, 0.057, 0.054) * (1.0 + 0.5 * smoothstep(-0.4, 0.0, d.y));
    vec3 c = d.y >= 0.0 ? sky : floor_color;
    c += vec3(0.25) * pow(max(1.0 - abs(d.y), 0.0), 12.0);   // horizon; |d.y| may exceed 1 by an ulp
    c += vec3(3.2, 3.3, 3.6) * soft_cap(d, normalize(vec3(0.75, 0.35, 0.55)), 0.30, 0.08); // fill box
    c += vec3(4.0, 3.8, 3.5) * soft_cap(d, normalize(vec3(-0.35, 0.45, -0.82)), 0.20, 0.05); // rim
    c += vec3(1.2) * soft_cap(d, vec3(0.0, 1.0, 0.0), 0.35, 0.15);                         // top box
    return c * u_env_intensity;
#elif ENV == sky
    float up = saturate(d.y);
    vec3 zenith = vec3(0.12, 0.25, 0.60), horizon = vec3(0.75, 0.82, 0.95);
    vec3 sky = mix(horizon, zenith, pow(up, 0.45));
    float mu = max(dot(d, u_sun_direction), 0.0);
    sky += vec3(1.0, 0.85, 0.6) * (0.6 * pow(mu, 8.0) + 2.0 * pow(mu, 64.0));            // glow
    vec3 ground = vec3(0.22, 0.19, 0.15) * (0.6 + 0.4 * smoothstep(-0.3, 0.0, d.y));
    vec3 c = d.y >= 0.0 ? sky : ground;
    c += vec3(0.3, 0.3, 0.32) * pow(max(1.0 - abs(d.y), 0.0), 16.0);                      // haze
    return c * u_env_intensity;
#elif ENV == file
    vec2 uv = vec2(atan(d.x, -d.z) * (0.5 * INV_PI) + 0.5, acos(clamp(d.y, -1.0, 1.0)) * INV_PI);
    return textureLod(u_env_map, uv, 0.0).rgb * u_env_intensity;
#endif
}
