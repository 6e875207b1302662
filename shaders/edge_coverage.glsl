// Analytic anti-aliasing of the cells stage's sphere (ANALYTIC_AA): the pixel box the
// reference integrates, split at the sphere's silhouette. Across one pixel the silhouette
// distance s (distance of the ray from the sphere's centre minus the radius) is linear in the
// pixel coordinates to well under 1 %, so the covered fraction of the box is the probability
// that s(centre) + U_a + U_b < 0, U_a, U_b uniform of widths |ds/dx|, |ds/dy|: the CDF of a
// trapezoid. Edge pixels shade one ray on each side of the silhouette and blend them by it.

// Distance of the ray through `pixel` (cell frame) from the sphere at the origin, minus R.
float silhouette_distance(vec2 pixel) {
    vec3 rd;
    vec3 ro = camera_ray(2.0 * pixel / u_resolution - 1.0, rd);
    return length(cross(-ro, rd)) - u_radius;   // |centre - ro| sin(angle to the centre)
}

// P(x + U_a + U_b < 0): the share of the pixel box inside the silhouette.
float box_coverage(float x, float a, float b) {
    float w_max = max(a, b), w_min = min(a, b);
    float h = 0.5 * (a + b);
    float y = -x;                                  // P(U_a + U_b < y)
    if (y <= -h) return 0.0;
    if (y >= h) return 1.0;
    float flat_half = 0.5 * (w_max - w_min);
    if (abs(y) <= flat_half || w_min < 1e-6 * w_max) return saturate(0.5 + y / w_max);
    float tail = sq(h - abs(y)) / (2.0 * a * b);   // the quadratic ends of the trapezoid's CDF
    return y < 0.0 ? tail : 1.0 - tail;
}

struct EdgeSplit {
    float coverage;   // share of the pixel box covered by the sphere
    vec2 inside;      // a pixel position whose ray hits the sphere (inside the covered part)
    vec2 outside;     // one whose ray passes beside it
};

// The split of the pixel centred at `centre` (cell frame); coverage 0 or 1 away from edges.
EdgeSplit edge_split(vec2 centre) {
    float s = silhouette_distance(centre);
    vec2 grad = vec2(silhouette_distance(centre + vec2(1.0, 0.0)),
                     silhouette_distance(centre + vec2(0.0, 1.0))) - s;
    float a = abs(grad.x), b = abs(grad.y);
    float c = box_coverage(s, a, b);
    // Sample points a quarter of the box's extent along s into each side (or the centre when
    // it is already that deep): roughly the centroids of the two parts.
    float g2 = max(dot(grad, grad), 1e-30);
    float depth = 0.25 * (a + b);
    vec2 inside = centre - grad * ((s - min(s, -depth)) / g2);
    vec2 outside = centre - grad * ((s - max(s, depth)) / g2);
    return EdgeSplit(c, inside, outside);
}
