"""A silhouette pixel's covered part is shaded at points that share it evenly across the
silhouette (edge_coverage.glsl, its float64 model sdfpbr.oracle.edge): the rule itself against
exact box integrals, and the chart's pixels against the rule with the float64 BRDF."""
import dataclasses
import math

import numpy as np
import pytest

from sdfpbr.oracle import edge, shading_model
from sdfpbr.shading.plan import chart_frame
from sdfpbr.spec.chart_spec import make_spec


def test_the_quantile_inverts_the_coverage():
    rng = np.random.default_rng(7)
    a, b = rng.uniform(0.0, 2.0, 4000), rng.uniform(0.0, 2.0, 4000)
    a[:200] = 0.0                                       # a silhouette along a pixel axis
    b[200:400] = a[200:400]                             # at 45 degrees: a triangle, no flat top
    p = rng.uniform(0.0, 1.0, 4000)
    p[:20], p[20:40] = 0.0, 1.0
    y = edge.box_quantile(p, a, b)
    np.testing.assert_allclose(edge.box_coverage(-y, a, b), p, atol=1e-9)
    assert edge.box_quantile(0.3, 0.0, 0.0) == 0.0      # no gradient: the centre
    # and the coverage is the box's share, counted on a fine grid of the box
    u = (np.arange(400) + 0.5) / 400 - 0.5
    for s0, ga, gb in [(0.1, 0.7, 0.3), (-0.35, 0.5, 0.5), (0.0, 1.0, 0.0), (0.6, 0.9, 0.4)]:
        share = np.mean(s0 + ga * u[:, None] + gb * u[None, :] < 0)
        assert abs(edge.box_coverage(s0, ga, gb) - share) < 2.5e-3   # the grid's 1/400 per row


# The sphere's shading across a silhouette pixel: N.V of an orthographic sphere of radius R px
# at distance -s px inside its silhouette is sqrt(1 - (1 + s / R)^2) ~ sqrt(-2 s / R), as
# steep as a function gets there. The covered part's mean on a 2000 x 2000 grid of the box
# against the rule's, for boxes the silhouette crosses at every depth and angle.
def _covered_means(samples, radius_px=12.0, n=2000):
    rng = np.random.default_rng(3)
    angle = rng.uniform(0.0, 0.5 * math.pi, 40)
    s0 = rng.uniform(-0.7, 0.7, 40)
    u = (np.arange(n) + 0.5) / n - 0.5
    exact, rule, old = [], [], []
    for th, s in zip(angle, s0):
        g = np.array([math.cos(th), math.sin(th)])        # the distance's gradient, 1 px per px
        c = float(edge.box_coverage(s, abs(g[0]), abs(g[1])))
        if not 0.02 < c < 0.98:
            continue
        def shading(d):
            return np.sqrt(np.clip(1.0 - (1.0 + d / radius_px) ** 2, 0.0, 1.0))
        d = s + g[0] * u[:, None] + g[1] * u[None, :]
        exact.append(shading(d)[d < 0].mean())
        points = edge.edge_sample_points(np.zeros(2), s, g, samples)
        rule.append(shading(s + points @ g).mean())
        depth = 0.25 * (abs(g[0]) + abs(g[1]))            # the rule before: a quarter of the box in
        old.append(shading(min(s, -depth)))
    return np.array(exact), np.array(rule), np.array(old)


def test_the_rule_approaches_the_covered_parts_mean():
    """One point at the median errs by the curvature of the shading over the covered part; n
    points at the midpoints of n equal shares by about 1 / n^1.5 of that for a square root
    (its error concentrates in the last share, whose width shrinks as 1 / n). The bounds are
    those orders from the one-point error, with the grid's own 1e-3."""
    exact, one, old = _covered_means(1)
    _, four, _ = _covered_means(4)
    e1, e4, e_old = (np.abs(x / exact - 1) for x in (one, four, old))
    assert len(exact) > 20
    assert e1.mean() < 0.5 * e_old.mean()          # the median, not a fixed depth
    assert e4.max() < e1.max() / 4 ** 1.5 * 2 + 1e-3
    assert e4.mean() < e1.mean() / 4 ** 1.5 * 2 + 1e-3


SIZE = 160
LIT = dict(rows=1, cols=1, width=SIZE, height=SIZE, env="black", ibl=False, ground=False, labels=False,
           metallic=(0.0, 0.0), roughness=(0.6, 0.6), base_color=(0.8, 0.8, 0.8), multiscatter=False,
           tonemap="none", exposure=0.0)


def _mirror_edge(spec, samples, s_error=0.0):
    """Per pixel of the image (rows top down): the coverage edge_coverage.glsl computes, and
    the covered part's radiance under a light along the view, as the mean of the float64 BRDF
    at the rule's points; plus how far in (world units) the rule's shallowest point lies.
    s_error: added to the silhouette distance the rule starts from (the sphere stays)."""
    cam = chart_frame(spec).camera
    H, W = cam.height, cam.width
    ys, xs = np.mgrid[0:H, 0:W]
    x, y = xs + 0.5, H - ys - 0.5                       # GL pixel centres

    def distance(px, py):
        ro, rd = cam.rays(2.0 * px / W - 1.0, 2.0 * py / H - 1.0)
        return np.linalg.norm(np.cross(-ro, rd), axis=-1) - spec.sphere_radius, ro, rd
    s0 = distance(x, y)[0]
    grad = np.stack([distance(x + 1.0, y)[0] - s0, distance(x, y + 1.0)[0] - s0], -1)
    s0 = s0 + s_error
    coverage = edge.box_coverage(s0, np.abs(grad[..., 0]), np.abs(grad[..., 1]))
    points = edge.edge_sample_points(np.stack([x, y], -1), s0, grad, samples)
    depth, ro, rd = distance(points[..., 0], points[..., 1])
    b = (ro * rd).sum(-1)
    t = -b - np.sqrt(np.maximum(b * b - ((ro * ro).sum(-1) - spec.sphere_radius ** 2), 0.0))
    n = shading_model.normalize(ro + rd * t[..., None])
    light = spec.lights[0]
    f = shading_model.brdf(n, -rd, np.broadcast_to(np.asarray(light.direction), n.shape), spec.base_color,
                    0.0, spec.roughness[0])
    radiance = f * (light.intensity * np.clip((n * np.asarray(light.direction)).sum(-1), 0, 1))[..., None]
    return coverage, radiance.mean(-2), -depth.max(-1)


@pytest.mark.parametrize("samples", [1, 4])
def test_silhouette_pixels_shade_the_rules_points(session, monkeypatch, samples):
    """A rough white sphere lit only by a light behind the camera, nothing else in view: each
    silhouette pixel is its coverage times the covered part's radiance at the rule's points.
    Bound: float32 computes the silhouette distance the rule starts from as a cross product of
    world vectors as long as the camera's distance, so a few (16) ulps of that; the coverage and
    the points' radiance move across it by their slope there, which the mirror measures at
    each pixel for an error of either sign, plus PROGRAM_RTOL of the shading's own roundings."""
    from sdfpbr.spec.presets import QUALITY_PRESETS
    from helpers import PROGRAM_RTOL
    monkeypatch.setitem(QUALITY_PRESETS, "default", dataclasses.replace(QUALITY_PRESETS["default"],
                                                                        edge_samples=samples))
    cam = chart_frame(make_spec(**LIT)).camera
    towards_camera = (-cam.forward).tolist()
    spec = make_spec(**LIT, lights=[{"kind": "directional", "direction": towards_camera, "intensity": 2.0}])
    result = session.render(spec)
    coverage, radiance, depth = _mirror_edge(spec, samples)
    ulps = 16 * np.finfo(np.float32).eps * float(np.linalg.norm(cam.position))
    moved = [_mirror_edge(spec, samples, s_error=e) for e in (-ulps, ulps)]
    crossed = (coverage > 0.05) & (coverage < 0.95) & (depth > 4 * ulps)   # every point well inside
    assert crossed.sum() > 100
    gpu_coverage = result.aov["coverage"]
    coverage_bound = np.maximum(*(np.abs(c - coverage) for c, _, _ in moved))
    assert (np.abs(gpu_coverage - coverage) <= coverage_bound)[crossed].all()
    # the covered part's radiance: the chart's pixel over its coverage
    mean = result.hdr / np.maximum(gpu_coverage, 1e-30)[..., None]
    err = np.abs(mean - radiance).max(-1)
    bound = np.maximum(*(np.abs(r - radiance).max(-1) for _, r, _ in moved)) + PROGRAM_RTOL * radiance.max(-1)
    worst = np.argmax((err - bound)[crossed])
    assert (err <= bound)[crossed].all(), (err[crossed][worst], bound[crossed][worst])
