// What a ray that meets nothing sees: the environment and the lights' discs. A transparent
// image has none: premultiplied, a miss adds no colour, only less coverage.
vec3 background(vec3 rd) {
#if TRANSPARENT
    return vec3(0.0);
#endif
    vec3 c = env_radiance(rd);
#if NUM_DIR_LIGHTS > 0
    c += light_discs(rd);
#endif
    return c;
}
