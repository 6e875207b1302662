// Analytic anti-aliasing of the spheres (ANALYTIC_AA): the pixel box the
// reference integrates, split at the sphere's silhouette. Across one pixel the silhouette
// distance s (distance of the ray from the sphere's centre minus the radius) is linear in the
// pixel coordinates to well under 1 %, so the covered fraction of the box is the probability
// that s(centre) + U_a + U_b < 0, U_a, U_b uniform of widths |ds/dx|, |ds/dy|: the CDF of a
// trapezoid. Edge pixels shade the covered part at EDGE_SAMPLES points spread along s (one:
// its median) and the rest at one point, and blend them by it.

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
    vec2 inside;      // the covered part's deepest sample point (edge_sample_point 0)
    vec2 outside;     // a point whose ray passes beside the sphere
    vec2 centre;      // the pixel's centre
    vec2 grad;        // the silhouette distance's change per pixel along x and y
};

// The point at quantile p of the silhouette distance over the box (s + U_a + U_b), on the line
// through the centre along the distance's gradient (up to ~0.1 px outside the box where the
// silhouette crosses it aslant: the distance is what the shading follows).
vec2 edge_point(EdgeSplit split, float p) {
    vec2 g = split.grad;
    return split.centre + g * (box_quantile(p, abs(g.x), abs(g.y)) / max(dot(g, g), 1e-30));
}

// The covered part's sample k of EDGE_SAMPLES: at its quantile (k + 1/2) / EDGE_SAMPLES, so
// the samples share it evenly along the distance, across which the sphere's shading changes
// fastest (one sample: the median). Sample 0 is the deepest.
vec2 edge_sample_point(EdgeSplit split, int k) {
    return edge_point(split, split.coverage * (float(k) + 0.5) / float(EDGE_SAMPLES));
}

// The split of the pixel centred at `centre` (cell frame on the cells stage); coverage 0 or 1
// away from edges.
EdgeSplit edge_split(vec2 centre) {
    vec3 sphere = silhouette_centre(centre);
    float s = silhouette_distance(centre, sphere);
    vec2 grad = vec2(silhouette_distance(centre + vec2(1.0, 0.0), sphere),
                     silhouette_distance(centre + vec2(0.0, 1.0), sphere)) - s;
    float a = abs(grad.x), b = abs(grad.y);
    EdgeSplit split = EdgeSplit(box_coverage(s, a, b), centre, centre, centre, grad);
    split.inside = edge_sample_point(split, 0);
    // Outside, a quarter of the box's extent beyond the silhouette (or the centre when it is
    // already that far): the floor there changes slowly, and a ray that close to the sphere
    // could count as meeting it.
    split.outside = centre - grad * ((s - max(s, 0.25 * (a + b))) / max(dot(grad, grad), 1e-30));
    return split;
}
