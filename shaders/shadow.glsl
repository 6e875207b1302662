// The area of a circle's segment cut off at half-angle alpha (at the circle's centre), over r^2:
// alpha - sin(alpha) cos(alpha), whose terms cancel to 2/3 alpha^3 as alpha falls (the sphere's
// side of a small sun's disc): by its series there.
float segment_area(float alpha) {
    float a2 = alpha * alpha;
    return alpha < 0.3 ? alpha * a2 * (2.0 / 3.0 - a2 * (2.0 / 15.0 - a2 * (4.0 / 315.0)))
                       : alpha - 0.5 * sin(2.0 * alpha);
}

// The visible fraction of a disc light (angular radius a, direction rd) from ro past one sphere
// (centre c): one minus the overlap of the light's disc with the sphere's silhouette (angular
// radius s) at angular separation g, over the disc's area — two circles, planar in angle (error
// O(a^2) for the small sun). The overlap is the two circles' segments on either side of their
// common chord (half-length h, at d_a from the light's centre and d_s from the silhouette's),
// every angle from atan: a 1-degree sun's penumbra took its edge from asin and acos, which
// llvmpipe evaluates to 4e-4 and 2e-4 rad, and the textbook lens formula's s^2 acos(...) -
// sqrt(...) cancels to a^2 scale, multiplying that by (s / a)^2 (a 1-degree sun's share off
// by up to 0.0135, tests/test_alpha.py; now 0.0019, the 8-bit half step).
float disc_visibility(vec3 ro, vec3 rd, float a, vec3 c) {
    vec3 to_c = c - ro;
    float dist = length(to_c);
    float s = atan(u_radius, sqrt(max(dist * dist - u_radius * u_radius, 0.0)));
    vec3 u = to_c / dist;
    float g = atan(length(cross(u, rd)), dot(u, rd));
    if (g >= a + s) return 1.0;
    if (g <= s - a) return 0.0;
    if (g <= a - s) return 1.0 - sq(s / a);
    float d_a = ((g - s) * (g + s) + a * a) / (2.0 * g);   // signed: beyond the light's centre when < 0
    float d_s = g - d_a;
    float h = sqrt(max(a * a - d_a * d_a, 0.0));
    float overlap = a * a * segment_area(atan(h, d_a)) + s * s * segment_area(atan(h, d_s));
    return saturate(1.0 - overlap / (PI * a * a));
}

#if STAGE == cells
#include "ray_sphere.glsl"
// The cells stage: the only occluder is the cell's sphere (radius u_radius at the origin), so
// the visible fraction of a disc light is exact (disc_visibility).
float soft_shadow(vec3 ro, vec3 rd, float k) {
    return disc_visibility(ro, rd, atan(1.0 / k), vec3(0.0));
}

// A point light's visibility from p: whether the segment to it misses the sphere (exact).
float point_shadow(vec3 p, vec3 l, float dist) {
    float t = ray_sphere(p, l, vec3(0.0), u_radius);
    return t > 0.0 && t < dist ? 0.0 : 1.0;
}

// A point light's visible share from the floor point p (ro: p lifted off the floor): a point's
// exact, a sphere light's disc against the sphere's as the sun's; a light nearer than the
// sphere's near side cannot be hidden by it.
float point_light_visibility(vec3 ro, vec3 p, vec3 l, float dist, float angle) {
    return angle <= 0.0 ? point_shadow(ro, l, dist)
         : dist > length(p) - u_radius ? soft_shadow(ro, l, 1.0 / tan(angle)) : 1.0;
}

// The floor's shadow averaged over the pixel's box (the reference's pixel integral) at four
// points of a rotated grid on the box's footprint: a pixel_size square across the ray (one
// side level, as the camera's right is), slid along the ray onto the floor. A little in front
// of the sphere the key light's penumbra is narrower than a pixel (the light's angle times
// the distance to the sphere's silhouette, which falls to 0 at the contact), and one point
// sample there stepped from umbra to light between two rows (10-20 % off each side of the
// step against the reference). v: towards the eye.
const vec2 FOOTPRINT_POINTS[4] = vec2[4](vec2(0.125, 0.375), vec2(0.375, -0.125), vec2(-0.125, -0.375),
                                         vec2(-0.375, 0.125));

// The footprint's sides on the floor (tests/test_alpha.py mirrors them in float64).
void floor_footprint(vec3 v, float pixel_size, out vec3 ex, out vec3 ey) {
    vec2 across = vec2(v.z, -v.x);
    float len = length(across);
    vec3 h = len > 1e-6 ? vec3(across.x, 0.0, across.y) / len : vec3(1.0, 0.0, 0.0);
    vec3 w = cross(v, h);
    ex = pixel_size * h;
    ey = pixel_size * (w - v * (w.y / max(v.y, 0.05)));   // the far floor's grazing footprint, capped
    ey.y = 0.0;   // on the floor, capped or not
}

// The k-th point's offset from the footprint's centre.
vec3 footprint_offset(int k, vec3 ex, vec3 ey) {
    return FOOTPRINT_POINTS[k].x * ex + FOOTPRINT_POINTS[k].y * ey;
}

// A disc light's (direction l, angular radius a) visible share over the footprint of the floor
// point lifted to ro.
float footprint_shadow(vec3 ro, vec3 v, float pixel_size, vec3 l, float a) {
    vec3 ex, ey;
    floor_footprint(v, pixel_size, ex, ey);
    float sum = 0.0;
    for (int i = 0; i < 4; ++i)
        sum += disc_visibility(ro + footprint_offset(i, ex, ey), l, a, vec3(0.0));
    return 0.25 * sum;
}

// A point light's (point_light_visibility), its direction and distance those of the footprint's
// centre (they turn by a pixel's angle as seen from the light across it).
float footprint_point_visibility(vec3 ro, vec3 p, vec3 v, float pixel_size, vec3 l, float dist, float angle) {
    vec3 ex, ey;
    floor_footprint(v, pixel_size, ex, ey);
    float sum = 0.0;
    for (int i = 0; i < 4; ++i) {
        vec3 o = footprint_offset(i, ex, ey);
        sum += point_light_visibility(ro + o, p + o, l, dist, angle);
    }
    return 0.25 * sum;
}
#elif SCENE_SDF == nearest_cell
// The shared stage: the spheres stand in the plane z = 0, so a ray towards a light meets only
// those near where it crosses the slab |z| <= radius (widened by the light's cone), up to
// `far`; each hides a share of the light's disc (disc_visibility) and what they let through
// multiplies, as if their silhouettes fell on the disc independently (off by h1 h2 - h12 where
// two meet: tests/test_alpha.py).
// The ground receives these shadows; a sphere's from its neighbours changed the default
// scene by nothing measurable (0.0780 -> 0.0781 mean FLIP at 256²) for 4 % more draw time.
const int MAX_SHADOW_SPHERES = 64;
uniform float u_shadow_far;

// The stretch [t0, t1] of the ray within the slab |z| <= half_width, up to far (t0 > t1: none).
vec2 slab_stretch(vec3 ro, vec3 rd, float half_width, float far) {
    if (abs(rd.z) <= 1e-6) return abs(ro.z) <= half_width ? vec2(0.0, far) : vec2(1.0, 0.0);
    float ta = (-half_width - ro.z) / rd.z, tb = (half_width - ro.z) / rd.z;
    return vec2(max(min(ta, tb), 0.0), min(max(ta, tb), far));
}

float grid_shadow(vec3 ro, vec3 rd, float a, float far) {
    float widen = tan(a);
    // The cone about the ray reaches widen * t further: the slab widened by that at its far end.
    vec2 stretch = slab_stretch(ro, rd, u_radius, far);
    if (stretch.x <= stretch.y) stretch = slab_stretch(ro, rd, u_radius + stretch.y * widen, far);
    float t0 = stretch.x, t1 = stretch.y;
    if (t1 < t0) return 1.0;
    vec3 e0 = ro + rd * t0, e1 = ro + rd * t1;
    float margin = u_radius + t1 * widen;
    vec2 half_extent = 0.5 * vec2(u_grid - 1) * u_spacing;
    vec2 lo = (vec2(min(e0.x, e1.x), -max(e0.y, e1.y)) - margin + half_extent) / u_spacing;
    vec2 hi = (vec2(max(e0.x, e1.x), -min(e0.y, e1.y)) + margin + half_extent) / u_spacing;
    ivec2 first = max(ivec2(ceil(lo)), ivec2(0));
    ivec2 last = min(ivec2(floor(hi)), u_grid - 1);
    float visible = 1.0;
    int tested = 0;
    for (int j = first.y; j <= last.y && tested < MAX_SHADOW_SPHERES; ++j)
        for (int i = first.x; i <= last.x && tested < MAX_SHADOW_SPHERES; ++i) {
            vec3 centre = cell_center(ivec2(i, j));
            visible *= 1.0 - light_ray_coverage(ivec2(i, j), centre, ro, rd, a) * (1.0 - disc_visibility(ro, rd, a, centre));
            ++tested;
        }
    return visible;
}

float soft_shadow(vec3 ro, vec3 rd, float k) {
    return grid_shadow(ro, rd, atan(1.0 / k), u_shadow_far);
}
#else
// The seed002 preset's union of every sphere: soft shadows by sphere tracing towards the key light
// (Inigo Quilez's improved technique). k = 1 / tan(angular radius) makes the penumbra match
// the light's size.
uniform int u_shadow_steps;
uniform float u_shadow_far;

float soft_shadow(vec3 ro, vec3 rd, float k) {
    float res = 1.0;
    float ph = 1e20;
    float t = 1e-3 * u_radius;
    for (int i = 0; i < u_shadow_steps; ++i) {
        float h = sdf_spheres(ro + rd * t);
        if (h < 1e-4 * u_radius) return 0.0;
        float y = h * h / (2.0 * ph);
        float d = sqrt(max(h * h - y * y, 0.0));
        res = min(res, k * d / max(1e-6, t - y));
        ph = h;
        t += h;
        if (t > u_shadow_far) break;
    }
    res = saturate(res);
    return res * res * (3.0 - 2.0 * res);
}
#endif
