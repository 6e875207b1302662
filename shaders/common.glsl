// Constants and safe math shared by every program.
#define PI 3.14159265358979
#define INV_PI 0.31830988618379
#define GOLDEN_ANGLE 2.39996323   // pi (3 - sqrt 5): spiral points spread evenly
// Filament's fp32 guards (docs/model.md, conventions): r >= 0.045 keeps alpha^2 normal; NdotV >= 1e-4.
#define MIN_PERCEPTUAL_ROUGHNESS 0.045
#define MIN_N_DOT_V 1e-4
#define DIELECTRIC_F0 0.04   // ior 1.5

float saturate(float x) { return clamp(x, 0.0, 1.0); }
vec3 saturate(vec3 x) { return clamp(x, 0.0, 1.0); }
float sq(float x) { return x * x; }
float max3(vec3 v) { return max(v.x, max(v.y, v.z)); }
float luminance(vec3 c_linear) { return dot(c_linear, vec3(0.2126, 0.7152, 0.0722)); }   // Rec. 709

// (1 - x)^5 with x clamped first: pow() of a negative base is undefined in GLSL.
float pow5_one_minus(float x) {
    float m = 1.0 - saturate(x);
    float m2 = m * m;
    return m2 * m2 * m;
}

// Direction k of `count` spread evenly (equal solid angles: a spiral of golden-angle turns) over
// the unit sphere above height y_min (-1: all of it).
vec3 spiral_direction(int k, int count, float y_min) {
    float y = 1.0 - (float(k) + 0.5) / float(count) * (1.0 - y_min);
    float r = sqrt(max(1.0 - y * y, 0.0));
    float phi = GOLDEN_ANGLE * float(k);
    return vec3(r * cos(phi), y, r * sin(phi));
}

// Orthonormal basis around n (Duff et al. 2017): no normalize, no singularity except n.z = -1 handled by sign.
void basis(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}
