// Punctual lights. Directional: direction towards the light, illuminance (colour x intensity)
// and angular radius; point: position, intensity, range of the inverse-square window and the
// radius of its emitting sphere (0: a point).
// The composer emits the loops only for the light kinds the scene has.

#if NUM_DIR_LIGHTS > 0
uniform vec3 u_dir_light_direction[NUM_DIR_LIGHTS];
uniform vec3 u_dir_light_illuminance[NUM_DIR_LIGHTS];
uniform float u_dir_light_angular_radius[NUM_DIR_LIGHTS];

// The lights as seen in the background: discs of uniform radiance E / (pi sin^2 theta).
vec3 light_discs(vec3 rd) {
    vec3 sum = vec3(0.0);
    for (int i = 0; i < NUM_DIR_LIGHTS; ++i) {
        float theta = u_dir_light_angular_radius[i];
        if (theta > 0.0 && dot(rd, u_dir_light_direction[i]) >= cos(theta))
            sum += u_dir_light_illuminance[i] / (PI * sq(sin(theta)));
    }
    return sum;
}
#endif

#if NUM_POINT_LIGHTS > 0
uniform vec3 u_point_light_position[NUM_POINT_LIGHTS];
uniform vec3 u_point_light_intensity[NUM_POINT_LIGHTS];
uniform float u_point_light_range[NUM_POINT_LIGHTS];
uniform float u_point_light_radius[NUM_POINT_LIGHTS];

// The angle a point light's sphere subtends from distance dist: its disc, as a directional
// light's angular radius is.
float point_angular_radius(int i, float dist) {
    return asin(min(u_point_light_radius[i] / max(dist, 1e-30), 1.0));
}

// Inverse square with a smooth window to zero at the range (Karis 2013).
float point_falloff(float dist, float range) {
    float w = saturate(1.0 - sq(sq(dist / range)));
    return w * w / max(dist * dist, 1e-4);
}
#endif
