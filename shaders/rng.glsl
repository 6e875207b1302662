// Counter-based random numbers for the reference renderer. Every value is a hash of
// (pixel, sample index, draw counter) under a mask derived from the seed, so a sample's numbers
// do not depend on how samples are grouped into batches or on the order threads run.

// Jarzynski & Olano 2020, "Hash Functions for GPU Rendering": 4 x 32 bits in, 4 x 32 bits out.
uvec4 pcg4d(uvec4 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.w; v.y += v.z * v.x; v.z += v.x * v.y; v.w += v.y * v.z;
    v ^= v >> 16u;
    v.x += v.y * v.w; v.y += v.z * v.x; v.z += v.x * v.y; v.w += v.y * v.z;
    return v;
}

struct Rng {
    uvec4 key;      // (pixel, sample) xor the seed mask; w xor the counter picks the draw
    uint counter;
};

Rng rng_init(uvec2 pixel, uint sample_index, uint seed) {
    uvec4 mask = pcg4d(uvec4(seed, 0x9e3779b9u, 0x85ebca6bu, 0xc2b2ae35u));
    return Rng(uvec4(pixel, sample_index, 0u) ^ mask, 0u);
}

uvec4 rng_next_bits(inout Rng r) {
    uvec4 h = pcg4d(r.key ^ uvec4(0u, 0u, 0u, r.counter));
    r.counter += 1u;
    return h;
}

// Four uniform numbers in [0, 1) with 24 bits each (exactly representable in float32).
vec4 rng_next4(inout Rng r) {
    return vec4(rng_next_bits(r) >> 8u) * (1.0 / 16777216.0);
}
