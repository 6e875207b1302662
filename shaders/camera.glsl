// Primary rays. The camera basis and projection come from Python (sdfpbr/camera.py), which
// also projects sphere centres for the chart labels, so both agree by construction.
uniform vec3 u_cam_position;
uniform vec3 u_cam_right;
uniform vec3 u_cam_up;
uniform vec3 u_cam_forward;
uniform float u_cam_half_height;   // tan(fov/2) for perspective, half the view height for orthographic
uniform vec2 u_resolution;         // full image size in pixels (tiles cover parts of it)

// ndc in [-1, 1]^2, y up. Returns the ray origin; rd receives the unit direction.
vec3 camera_ray(vec2 ndc, out vec3 rd) {
    float aspect = u_resolution.x / u_resolution.y;
    vec2 s = ndc * vec2(aspect, 1.0) * u_cam_half_height;
#if CAMERA == perspective
    rd = normalize(u_cam_forward + s.x * u_cam_right + s.y * u_cam_up);
    return u_cam_position;
#elif CAMERA == orthographic
    rd = u_cam_forward;
    return u_cam_position + s.x * u_cam_right + s.y * u_cam_up;
#endif
}

// Pixel footprint at distance t: footprint.x + footprint.y * t (world units).
vec2 pixel_footprint() {
    float pixel = 2.0 * u_cam_half_height / u_resolution.y;
#if CAMERA == perspective
    return vec2(0.0, pixel);
#elif CAMERA == orthographic
    return vec2(pixel, 0.0);
#endif
}
