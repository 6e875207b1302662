"""Disc lights: a directional light with an angular radius is a disc of radiance
E / (pi sin^2 theta); the smoothest sphere must show it as that disc (its image placed by ray
geometry, its radiance the disc's own), not as a dead pixel or a blurred blob."""
import math

import numpy as np
import pytest

from sdfpbr.oracle import mirror
from sdfpbr.shading.camera import frame
from sdfpbr.spec.chart_spec import make_spec
from sdfpbr.tools.stress.checks import pixel_rays

SIZE = 400


@pytest.mark.parametrize("theta_deg", [5.0, 10.0])
def test_a_mirror_sphere_shows_a_disc_light_as_the_disc(session, theta_deg):
    """A white metal mirror (F = 1) under only a disc light that sits behind the camera: where the
    reflected ray points into the disc, the pixel holds the disc's radiance L = E / (pi sin^2 theta);
    where it points more than a margin outside, less than half of it. Which pixels are which
    comes from ray-sphere geometry here, not from the shader.

    The disc's radiance in the chart is E / (4 pi alpha'^2 N.V) with alpha'^2 = alpha^2 +
    sin^2(theta)/4 (brdf.glsl): relative error 4 alpha^2 / sin^2 theta (<= 0.26 % at 5 degrees,
    alpha = 0.045^2) plus 1/N.V - 1 (<= 0.25 %: the disc's image lies within theta/2 + 1 degree of
    the view direction); the tolerance is twice their sum. The margin: the reflected ray turns
    by up to 2 / (sphere radius in pixels) per pixel (two pixels of it, for the edge's
    anti-aliasing) and the lobe's own width falls to a quarter of its peak within 2 alpha."""
    theta = math.radians(theta_deg)
    base = dict(rows=1, cols=1, width=SIZE, height=SIZE, env="black", ibl=False, ground=False,
                metallic=(1.0, 1.0), roughness=(0.0, 0.0), base_color=(1.0, 1.0, 1.0), multiscatter=False,
                tonemap="none", exposure=0.0)
    cam = frame(make_spec(**base))
    # The light's axis: towards the camera, turned by 1 degree so the image is off-centre.
    axis = -cam.forward * math.cos(math.radians(1.0)) + cam.right * math.sin(math.radians(1.0))
    E = 2.0
    light = {"kind": "directional", "direction": axis.tolist(), "intensity": E, "angular_radius_deg": theta_deg}
    spec = make_spec(**base, lights=[light])
    hdr = session.render(spec).hdr.astype(np.float64)[..., :3]

    ro, rd = pixel_rays(cam, SIZE, SIZE)
    r = spec.sphere_radius
    b = (ro * rd).sum(-1)
    disc = b * b - ((ro * ro).sum(-1) - r * r)
    hit = disc > 0
    t = -b - np.sqrt(np.where(hit, disc, 0.0))
    n = mirror.normalize(ro + rd * t[..., None])
    reflected = mirror.reflect(rd, n)
    angle = np.arccos(np.clip(reflected @ axis, -1.0, 1.0))

    radius_px = r * np.abs(cam.project(np.zeros((1, 3)))[1][0])
    alpha = mirror.MIN_PERCEPTUAL_ROUGHNESS ** 2
    margin = 2 * 2.0 / radius_px + 2 * alpha
    L = E / (math.pi * math.sin(theta) ** 2)
    inside = hit & (angle < theta - margin)
    outside = hit & (angle > theta + margin)
    assert inside.sum() >= 12 and outside.sum() > 1000     # the disc's image is a disc, many pixels wide

    rtol = 2 * (4 * alpha ** 2 / math.sin(theta) ** 2 + (1 / math.cos(theta / 2 + math.radians(1.0)) - 1))
    np.testing.assert_allclose(hdr[inside], L, rtol=rtol)
    assert hdr[outside].max() < 0.5 * L
