// The cells stage's sphere light onto its floor comes two ways (stage_bounce.glsl): bounce rays,
// which shade the sphere at a few points, carry the smooth part; a closed form carries a smooth
// lobe's mirror image of the lights and of the sky. How much each takes, read by both sides.

// The share of a lobe's reflection the rays resolve: across the cap, the rays' hit points'
// reflected directions lie about a radian apart, so a lobe narrower than that (alpha below
// ~0.5) shows as blobs where a ray happens to find its highlight; the closed form takes it.
#define BOUNCE_LOBE_FROM 0.1
#define BOUNCE_LOBE_TO 0.5
float bounce_resolves(float alpha) {
    return smoothstep(BOUNCE_LOBE_FROM, BOUNCE_LOBE_TO, alpha);
}

#if BOUNCE_MIRROR_DIRECTIONS > 0
// How much of a smooth sphere's reflection towards its floor along a direction with height y
// stage_bounce.glsl mirrors in closed form (the sky, at infinity), and the rest the bounce rays
// carry (the floor, near): a ramp across the horizon.
#define MIRRORED_SKY_RAMP 0.1
float mirrored_sky_share(float y) {
    return smoothstep(-MIRRORED_SKY_RAMP, MIRRORED_SKY_RAMP, y);
}
#endif
