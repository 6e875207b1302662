"""Transparency that composites: a transparent chart laid onto a page colour is the chart
rendered onto that colour (the backdrop), and its floor is a shadow catcher whose alpha is the
sun's shadow of the sphere, placed where ray geometry says it is."""
import math

import numpy as np
import pytest

from sdfpbr.shading.camera import frame, ground_height
from sdfpbr.spec.chart_spec import make_spec

SUN = {"kind": "directional", "direction": [0.45, 0.8, 0.35], "intensity": 3.0, "angular_radius_deg": 1.0}


def composite(rgba_u8: np.ndarray, backdrop_srgb) -> np.ndarray:
    """A page's straight-alpha composite, in 8-bit steps, before rounding."""
    rgba = rgba_u8.astype(np.float64) / 255.0
    a = rgba[..., 3:]
    return 255.0 * (rgba[..., :3] * a + np.asarray(backdrop_srgb) * (1.0 - a))


@pytest.mark.parametrize("backdrop", [(1.0, 1.0, 1.0), (0.1, 0.2, 0.5)])
def test_a_transparent_chart_composited_onto_a_colour_is_the_chart_rendered_onto_it(session, backdrop):
    """Bound derived from 8-bit storage: the PNG's colour and alpha are each within half a step
    of the float values, so the composite is within 1 step of the exact one, and the backdrop
    render rounds that once more (half a step): 1.5 steps at most."""
    base = dict(rows=2, cols=2, width=96, height=96, lights=[SUN])
    transparent = session.render(make_spec(**base, transparent=True)).image
    onto = session.render(make_spec(**base, backdrop=backdrop)).image
    assert (onto[..., 3] == 255).all()
    alpha = transparent[..., 3]
    assert (alpha == 0).any() and (alpha == 255).any() and ((alpha > 0) & (alpha < 255)).any()
    assert np.abs(composite(transparent, backdrop) - onto[..., :3]).max() <= 1.5


@pytest.mark.parametrize("renderer", ["chart", "reference"])
def test_the_floor_is_a_shadow_catcher_whose_alpha_is_the_spheres_shadow(session, renderer):
    """Sun only (no environment light): the floor keeps no colour and its alpha is 1 minus the
    share of sunlight the sphere lets through, so it is opaque where the ray towards the sun
    passes well inside the sphere and clear where it passes well outside. Which is which comes
    from ray geometry here, not from the shader; the margin is the sun disc's penumbra (its
    angular radius times the distance to the sphere) and two pixels. The reference traces the
    floor's light with and without the sphere (direct light only: the share is then its exact
    visibility, 0 or 1 on every path outside the penumbra)."""
    spec = make_spec(rows=1, cols=1, width=160, height=160, env="black", ibl=False, lights=[SUN],
                     transparent=True)
    if renderer == "chart":
        image = session.render(spec).image
    else:
        from sdfpbr.tools.reference import render_reference
        image = render_reference(spec, samples=16, max_bounces=1, seed=4, session=session).image
    cam = frame(spec)
    r, floor_y = spec.sphere_radius, ground_height(spec)
    sun = np.asarray(SUN["direction"], float) / np.linalg.norm(SUN["direction"])
    tan_sun = math.tan(math.radians(SUN["angular_radius_deg"]))

    j, i = np.mgrid[:spec.height, :spec.width]
    ndc_x, ndc_y = 2 * (i + 0.5) / spec.width - 1, 1 - 2 * (j + 0.5) / spec.height
    d = (cam.forward + np.multiply.outer(ndc_x * cam.half_height * spec.width / spec.height, cam.right)
         + np.multiply.outer(ndc_y * cam.half_height, cam.up))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    t = (floor_y - cam.position[1]) / d[..., 1]
    p = cam.position + d * t[..., None]
    pixel = 2 * cam.half_height * t / spec.height          # a pixel's world size at p
    # Pixels whose camera ray passes near the sphere (it would hide or edge the floor) are left out.
    along = -(cam.position @ d.reshape(-1, 3).T).reshape(t.shape)
    miss = np.linalg.norm(cam.position + d * along[..., None], axis=-1)
    floor = (d[..., 1] < 0) & (miss > r + 2 * pixel)
    # The shadow ray from p towards the sun: how close it passes to the sphere's centre.
    s = -(p @ sun)
    passes = np.where(s > 0, np.linalg.norm(p + np.multiply.outer(s, sun), axis=-1), np.linalg.norm(p, axis=-1))
    margin = np.maximum(s, 0) * tan_sun + 2 * pixel
    umbra, lit = floor & (passes < r - margin), floor & (passes > r + margin)
    assert umbra.sum() > 100 and lit.sum() > 1000
    alpha, rgb = image[..., 3], image[..., :3]
    assert (alpha[umbra] == 255).all(), np.unique(alpha[umbra])
    assert (alpha[lit] == 0).all(), np.unique(alpha[lit])
    assert (rgb[floor & (alpha > 0)] == 0).all()            # a catcher has no colour of its own


def test_without_a_floor_transparency_is_the_spheres_coverage(session):
    """No floor: alpha is the spheres' coverage alone, with partial values on the silhouettes."""
    spec = make_spec(rows=1, cols=1, width=96, height=96, ground=False, transparent=True)
    alpha = session.render(spec).image[..., 3].astype(float) / 255
    cam = frame(spec)
    (cx, cy), scale = (v[0] for v in cam.project(np.zeros((1, 3))))
    j, i = np.mgrid[:spec.height, :spec.width]
    dist = np.hypot(i + 0.5 - cx, j + 0.5 - cy) - spec.sphere_radius * scale   # ~ px outside the disc
    assert (alpha[dist < -2] == 1).all() and (alpha[dist > 2] == 0).all()
    assert ((alpha > 0) & (alpha < 1))[np.abs(dist) < 1].mean() > 0.5
