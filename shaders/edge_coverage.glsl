// Analytic anti-aliasing of the spheres (ANALYTIC_AA): the pixel box the
// reference integrates, split at the sphere's silhouette. Across one pixel the silhouette
// distance s (distance of the ray from the sphere's centre minus the radius) is linear in the
// pixel coordinates to well under 1 %, so the covered fraction of the box is the probability
// that s(centre) + U_a + U_b < 0, U_a, U_b uniform of widths |ds/dx|, |ds/dy|: the CDF of a
// trapezoid. Edge pixels shade the covered part at its median point along s (or EDGE_SAMPLES
// points spread along it) and the rest at one point, and blend them by it.

#if STAGE == cells
// The cell's sphere, at the origin of the cell frame.
vec3 silhouette_centre(vec2 pixel) { return vec3(0.0); }
#else
// The shared stage: the sphere nearest where the ray through `pixel` crosses the spheres'
// plane z = 0 (the spheres never overlap on the image, so it is the one whose edge is near).
vec3 silhouette_centre(vec2 pixel) {
    vec3 rd;
    vec3 ro = camera_ray(2.0 * pixel / u_resolution - 1.0, rd);
    float t = abs(rd.z) > 1e-6 ? max(-ro.z / rd.z, 0.0) : 0.0;
    return cell_center(nearest_cell(ro + rd * t));
}
#endif

// Distance of the ray through `pixel` (cell frame on the cells stage) from the sphere at c,
// minus R.
float silhouette_distance(vec2 pixel, vec3 c) {
    vec3 rd;
    vec3 ro = camera_ray(2.0 * pixel / u_resolution - 1.0, rd);
    return length(cross(c - ro, rd)) - u_radius;   // |centre - ro| sin(angle to the centre)
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

// y with P(U_a + U_b < y) = p: the inverse of box_coverage's trapezoid CDF.
float box_quantile(float p, float a, float b) {
    float w_max = max(a, b);
    float h = 0.5 * (a + b);
    float p_tail = 0.5 * min(a, b) / max(w_max, 1e-30);   // the CDF where its flat top begins
    if (p < p_tail) return -h + sqrt(2.0 * a * b * p);
    if (p > 1.0 - p_tail) return h - sqrt(2.0 * a * b * (1.0 - p));
    return (p - 0.5) * w_max;
}

struct EdgeSplit {
    float coverage;   // share of the pixel box covered by the sphere
    vec2 inside;      // a pixel position whose ray hits the sphere (inside the covered part)
    vec2 outside;     // one whose ray passes beside it
    vec2 centre;      // the pixel's centre, the silhouette distance's gradient across the box
    vec2 grad;        // and its widths along x and y (edge_point)
    float a, b;
};

// The point of the pixel box at quantile p of the silhouette distance over the box (s + U_a +
// U_b), on the line through the centre along the distance's gradient: the covered part is
// p < coverage, and points at p = coverage (k + 0.5) / n share it evenly along the distance,
// across which the sphere's shading changes fastest.
vec2 edge_point(EdgeSplit split, float p) {
    return split.centre + split.grad * (box_quantile(p, split.a, split.b) / max(dot(split.grad, split.grad), 1e-30));
}
// The covered part's point at its own quantile q.
vec2 edge_inside_point(EdgeSplit split, float q) { return edge_point(split, q * split.coverage); }

// The split of the pixel centred at `centre` (cell frame on the cells stage); coverage 0 or 1
// away from edges.
EdgeSplit edge_split(vec2 centre) {
    vec3 sphere = silhouette_centre(centre);
    float s = silhouette_distance(centre, sphere);
    vec2 grad = vec2(silhouette_distance(centre + vec2(1.0, 0.0), sphere),
                     silhouette_distance(centre + vec2(0.0, 1.0), sphere)) - s;
    float a = abs(grad.x), b = abs(grad.y);
    float c = box_coverage(s, a, b);
    EdgeSplit split = EdgeSplit(c, centre, centre, centre, grad, a, b);
    // Inside, the covered part's median point along the distance: the sphere's shading
    // changes fast across its silhouette. Outside, a quarter of the box's extent beyond the
    // silhouette (or the centre when it is already that far): the floor there changes slowly,
    // and a ray that close to the sphere could count as meeting it.
    float g2 = max(dot(grad, grad), 1e-30);
    split.inside = edge_inside_point(split, 0.5);
    split.outside = centre - grad * ((s - max(s, 0.25 * (a + b))) / g2);
    return split;
}
