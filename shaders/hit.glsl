// What a primary ray found: the record both intersection methods fill.
struct Hit {
    float t;        // ray parameter, < 0 for a miss
    vec3 normal;    // unit surface normal
    ivec2 cell;     // (col, row) of the sphere, (-1, -1) for the ground
};

const Hit NO_HIT = Hit(-1.0, vec3(0.0), ivec2(-1));
