// Cubemap texel <-> direction, in the GL face order +X -X +Y -Y +Z -Z.
vec3 cube_direction(int face, vec2 texel_center, float size) {
    vec2 st = 2.0 * texel_center / size - 1.0;
    vec3 d;
    if (face == 0) d = vec3(1.0, -st.y, -st.x);
    else if (face == 1) d = vec3(-1.0, -st.y, st.x);
    else if (face == 2) d = vec3(st.x, 1.0, st.y);
    else if (face == 3) d = vec3(st.x, -1.0, -st.y);
    else if (face == 4) d = vec3(st.x, -st.y, 1.0);
    else d = vec3(-st.x, -st.y, -1.0);
    return normalize(d);
}

// Solid angle of a texel (exact integral of the face projection, Driscoll).
float texel_solid_angle(vec2 texel_center, float size) {
    vec2 st = 2.0 * texel_center / size - 1.0;
    float h = 1.0 / size;
    vec2 a = st - h, b = st + h;
    #define AREA(x, y) atan((x) * (y), sqrt((x) * (x) + (y) * (y) + 1.0))
    return AREA(a.x, a.y) - AREA(a.x, b.y) - AREA(b.x, a.y) + AREA(b.x, b.y);
    #undef AREA
}
