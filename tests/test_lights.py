"""Disc lights: a directional light with an angular radius is a disc of radiance
E / (pi sin^2 theta), a point light with a radius a sphere of radiance I / (pi R^2); the
smoothest sphere must show either as that disc (its image placed by ray geometry, its radiance
the light's own), not as a dead pixel or a blurred blob -- in the chart and in the reference."""
import math

import numpy as np
import pytest

from sdfpbr.oracle import shading_model
from sdfpbr.shading.plan import chart_frame
from sdfpbr.spec.chart_spec import make_spec
from sdfpbr.features.reference import render_reference

SIZE = 400


MIRROR = dict(rows=1, cols=1, width=SIZE, height=SIZE, env="black", ibl=False, ground=False,
              metallic=(1.0, 1.0), roughness=(0.0, 0.0), base_color=(1.0, 1.0, 1.0), multiscatter=False,
              tonemap="none", exposure=0.0)
FAR = 50.0    # a point light's distance: its sphere's angle changes by 2 % across the mirror


def disc_scene(kind: str, theta: float, turn_deg: float = 1.0):
    """A light of angular radius theta (seen from the sphere's centre) behind the camera, turned
    by turn_deg so its image is off-centre (at half that angle on the sphere); returns (spec,
    axis, radiance L of the light)."""
    cam = chart_frame(make_spec(**MIRROR)).camera
    axis = -cam.forward * math.cos(math.radians(turn_deg)) + cam.right * math.sin(math.radians(turn_deg))
    if kind == "directional":
        E = 2.0
        light = {"kind": "directional", "direction": axis.tolist(), "intensity": E,
                 "angular_radius_deg": math.degrees(theta)}
        return make_spec(**MIRROR, lights=[light]), axis, E / (math.pi * math.sin(theta) ** 2)
    radius, intensity = FAR * math.sin(theta), 2.0 * FAR ** 2
    light = {"kind": "point", "position": (axis * FAR).tolist(), "intensity": intensity, "radius": radius,
             "range": 1e9}
    return make_spec(**MIRROR, lights=[light]), axis, intensity / (math.pi * radius ** 2)


def disc_image(spec, axis, theta):
    """Per pixel: whether the camera ray hits the sphere, and the angle between its mirror
    reflection and the light's axis; and the margin of one edge (see below)."""
    cam = chart_frame(spec).camera
    ro, rd = cam.pixel_rays()
    r = spec.sphere_radius
    b = (ro * rd).sum(-1)
    disc = b * b - ((ro * ro).sum(-1) - r * r)
    hit = disc > 0
    t = -b - np.sqrt(np.where(hit, disc, 0.0))
    n = shading_model.normalize(ro + rd * t[..., None])
    angle = np.arccos(np.clip(shading_model.reflect(rd, n) @ axis, -1.0, 1.0))
    radius_px = r * np.abs(cam.project(np.zeros((1, 3)))[1][0])
    margin = 2 * 2.0 / radius_px + 2 * shading_model.MIN_PERCEPTUAL_ROUGHNESS ** 2
    return hit, angle, margin


def disc_view_ratio(spec, axis):
    """Per pixel, V.H at the disc's centre over N.V: the chart sizes a disc's half vectors by
    the former (brdf.glsl disc_half_radius), a mirror's true half vector inside the image is N."""
    cam = chart_frame(spec).camera
    ro, rd = cam.pixel_rays()
    b = (ro * rd).sum(-1)
    disc = b * b - ((ro * ro).sum(-1) - spec.sphere_radius ** 2)
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    n = shading_model.normalize(ro + rd * t[..., None])
    v = -rd
    return (v * shading_model.normalize(v + axis)).sum(-1) / np.maximum((n * v).sum(-1), 1e-6)


@pytest.mark.parametrize("kind", ["directional", "point"])
@pytest.mark.parametrize("theta_deg, turn_deg", [(5.0, 1.0), (10.0, 1.0), (8.0, 60.0)])
def test_a_mirror_sphere_shows_a_disc_light_as_the_disc(session, kind, theta_deg, turn_deg):
    """A white metal mirror (F = 1) under only a disc light behind the camera, or turned 60
    degrees from it (its image 30 degrees round the sphere, N.V = 0.87): where the reflected
    ray points into the disc, the pixel holds the light's radiance L; where it points more than
    a margin outside, less than half of it. Which pixels are which comes from ray-sphere
    geometry here, not from the shader.

    Inside the disc's image the mirror's half vector is its normal, and the chart's disc
    radiance is L (V.H_c / N.V) / cos(theta_c) (ggx.glsl d_ggx_disc spreads the lobe over a
    disc of half vectors sized by V.H at the disc's centre, where the true one is N.V, and takes
    the measure's 1 / cos at the disc's centre, theta_c < theta / 2 from the normal). The
    tolerance: twice the largest |V.H_c / N.V - 1| over the inside pixels, plus 1 / cos(theta /
    2) - 1, plus the share of the lobe that falls outside the disc (GGX keeps r^2 / (r^2 + alpha^2)
    of itself within slope r of its centre, and inside the margin a circle of r = margin / 2 is
    within the disc: alpha^2 / ((margin / 2)^2 + alpha^2), alpha = 0.045^2). (A point light's
    E / sin^2 theta is I / R^2 from any distance.) The margin: the reflected ray turns by up to
    2 / (sphere radius in pixels) per pixel (two pixels of it, for the edge's anti-aliasing) and
    the lobe's own width falls to a quarter of its peak within 2 alpha."""
    theta = math.radians(theta_deg)
    spec, axis, L = disc_scene(kind, theta, turn_deg)
    hdr = session.render(spec).hdr.astype(np.float64)[..., :3]
    hit, angle, margin = disc_image(spec, axis, theta)
    inside, outside = hit & (angle < theta - margin), hit & (angle > theta + margin)
    assert inside.sum() >= 12 and outside.sum() > 1000     # the disc's image is a disc, many pixels wide
    alpha = shading_model.MIN_PERCEPTUAL_ROUGHNESS ** 2
    rtol = (2 * np.abs(disc_view_ratio(spec, axis)[inside] - 1).max() + 1 / math.cos(theta / 2) - 1
            + alpha ** 2 / ((margin / 2) ** 2 + alpha ** 2))
    np.testing.assert_allclose(hdr[inside], L, rtol=rtol)
    assert hdr[outside].max() < 0.5 * L


@pytest.mark.parametrize("kind", ["directional", "point"])
def test_the_reference_mirror_shows_the_light_at_its_radiance(session, kind):
    """The path tracer on the same mirror: inside the disc's image the pixels hold the light's
    radiance (the BRDF sample meets the disc or sphere: exact for a mirror up to the lobe's
    width), within 4 standard errors of their mean plus the lobe's share beyond the margin (as
    above)."""
    theta = math.radians(8.0)
    spec, axis, L = disc_scene(kind, theta)
    spec = make_spec(spec, width=320, height=320)
    res = render_reference(spec, samples=64, seed=3, session=session)
    hit, angle, margin = disc_image(spec, axis, theta)
    inside = hit & (angle < theta - margin)
    assert inside.sum() >= 12
    got = res.hdr.astype(np.float64)[..., :3][inside]
    stderr = float(np.sqrt((res.stderr.astype(np.float64)[inside] ** 2).sum()) / inside.sum())
    alpha = shading_model.MIN_PERCEPTUAL_ROUGHNESS ** 2
    lobe = alpha ** 2 / ((margin / 2) ** 2 + alpha ** 2)
    assert abs(got.mean() - L) <= 4 * stderr + lobe * L, (got.mean(), L, stderr, lobe)


def test_the_reference_lights_a_lambert_sphere_by_a_sphere_light_as_by_its_point(session):
    """A uniform sphere light seen whole from a surface point gives a Lambert surface there the
    irradiance of a point of the same intensity at its centre, I / d^2 (a lit sphere's outside
    field is its centre's); only points that see part of it below their horizon differ. The
    path tracer with every surface a Lambert reflector, lit by each, away from that band
    (N.L < sin(theta) plus a margin for a pixel's footprint): equal within 4 standard errors of
    the two renders' means. Sampling the sphere's cone (and MIS with the BRDF's rays that meet
    it) must add up to the point light's delta."""
    base = dict(rows=1, cols=1, width=96, height=96, env="black", ibl=False, ground=False,
                metallic=(0.0, 0.0), roughness=(1.0, 1.0), base_color=(0.8, 0.8, 0.8), tonemap="none")
    position = [-20.0, 30.0, 40.0]
    point = {"kind": "point", "position": position, "intensity": 2500.0, "range": 1e9}
    a, b = (make_spec(**base, lights=[light]) for light in (point, dict(point, radius=2.0)))
    ro, rd = chart_frame(a).camera.pixel_rays()
    bq = (ro * rd).sum(-1)
    disc = bq * bq - ((ro * ro).sum(-1) - a.sphere_radius ** 2)
    hit = disc > 0
    n = shading_model.normalize(ro + rd * (-bq - np.sqrt(np.where(hit, disc, 0.0)))[..., None])
    l = shading_model.normalize(np.asarray(position) - n)
    keep = hit & ((n * l).sum(-1) > 2.0 / np.linalg.norm(position) + 0.05)
    assert keep.sum() > 1000
    res = [render_reference(s, samples=32, seed=5, session=session, lambert=True) for s in (a, b)]
    ya, yb = (r.hdr.astype(np.float64)[..., :3][keep].mean() for r in res)
    se = math.hypot(*(float(np.sqrt((r.stderr.astype(np.float64)[keep] ** 2).sum()) / keep.sum()) for r in res))
    assert abs(ya - yb) <= 4 * se, (ya, yb, se)


@pytest.mark.parametrize("theta_deg", [6.0, 10.0])
@pytest.mark.parametrize("perceptual_roughness", [0.18, 0.25, 0.35, 0.5, 0.75, 1.0])
def test_a_disc_lights_highlight_holds_the_discs_light_where_the_disc_puts_it(perceptual_roughness, theta_deg):
    """float64: the light a white metal sphere sends to the camera from a disc light (the
    default studio's 6 and 10 degrees) 50 degrees off the view, summed over the sphere's
    visible normals (weighted by projected area), as the chart shades it (shading_model.brdf with
    disc_angular_radius: D averaged over the disc's half vectors in closed form, d_ggx_disc)
    and as the disc integrates it (the BRDF at 400 points spread evenly over the disc's solid
    angle): in total and in each band of angle from the highlight's centre (0-3, 3-6, 6-10,
    10-20, 20-40, 40-90 degrees: the last a rough lobe's far side, where the slope image's
    stretch is clamped). The closed form is exact for a circle in the lobe's slope space; the
    disc's slope image is an ellipse near it, and the other factors are taken at its centre:
    errors of second order in its size, sin^2(theta) (1.1 % at 6 degrees, 3.0 % at 10); the
    bound adds 1 % for the sums' own quadrature (from r = 0.18 the lobe is over three times the
    disc's point spacing; smoother lobes are the mirror tests' above). Karis's representative
    point with D renormalised to the disc's energy held the total within 3 % but put up to 1.5x
    of the light in the core and 0.2-0.6x in the tails."""
    rng = np.random.default_rng(1)
    theta, turn = math.radians(theta_deg), math.radians(50.0)
    v, l = np.array([0.0, 0.0, 1.0]), np.array([math.sin(turn), 0.0, math.cos(turn)])
    xy = rng.uniform(-1, 1, (40000, 2))
    xy = xy[(xy ** 2).sum(1) < 1][:20000]
    n = np.concatenate([xy, np.sqrt(1 - (xy ** 2).sum(1))[:, None]], 1)
    chart = (shading_model.brdf(n, v, l, 1.0, 1.0, perceptual_roughness, disc_angular_radius=theta)[:, 0]
             * np.clip(n @ l, 0, None))
    t1 = np.cross(l, [0.0, 1.0, 0.0])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(l, t1)
    k = np.arange(400)
    cos_t = 1 - (k + 0.5) / 400 * (1 - math.cos(theta))            # even in solid angle
    phi = 2 * math.pi * ((k * 0.6180339887) % 1.0)
    sin_t = np.sqrt(1 - cos_t ** 2)
    points = cos_t[:, None] * l + sin_t[:, None] * (np.cos(phi)[:, None] * t1 + np.sin(phi)[:, None] * t2)
    radiance = 1.0 / (math.pi * math.sin(theta) ** 2)                 # E = 1
    exact = sum(shading_model.brdf(n, v, np.broadcast_to(p, n.shape), 1.0, 1.0, perceptual_roughness)[:, 0]
                * np.clip(n @ p, 0, None) for p in points)
    exact = exact * radiance * 2 * math.pi * (1 - math.cos(theta)) / len(points)
    from_centre = np.degrees(np.arccos(np.clip(n @ shading_model.normalize(v + l), -1.0, 1.0)))
    bound = math.sin(theta) ** 2 + 0.01
    assert abs(chart.sum() / exact.sum() - 1) <= bound, chart.sum() / exact.sum()
    for lo, hi in [(0, 3), (3, 6), (6, 10), (10, 20), (20, 40), (40, 90)]:
        band = (from_centre >= lo) & (from_centre < hi)
        assert band.sum() > 50
        ratio = chart[band].sum() / exact[band].sum()
        assert abs(ratio - 1) <= bound, (lo, hi, ratio)
