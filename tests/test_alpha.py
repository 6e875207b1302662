"""Transparency that composites: a transparent chart laid onto a page colour is the chart
rendered onto that colour (the backdrop), and its floor is a shadow catcher whose alpha is the
sun's shadow of the sphere, placed where ray geometry says it is."""
import math

import numpy as np
import pytest

from sdfpbr.shading.camera import sphere_centers
from sdfpbr.shading.catcher import catcher_bands
from sdfpbr.shading.plan import chart_frame
from sdfpbr.spec.chart_spec import make_spec

from helpers import floor_points, footprint_offsets

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


def test_a_backdrop_is_the_page_under_the_labels_too(session):
    """A chart laid onto a page colour is laid onto it whole: its label margins are that colour
    (transparent or not), not the chart's dark ground."""
    from sdfpbr.image.chart_labels import label
    for transparent in (False, True):
        spec = make_spec(rows=1, cols=2, width=128, height=96, backdrop=(1.0, 0.9, 0.8), transparent=transparent)
        chart = label(spec, session.render(spec))
        for corner in (chart[0, 0], chart[-1, -1]):
            np.testing.assert_array_equal(corner, [255, 230, 204, 255])


@pytest.mark.parametrize("renderer", ["chart", "reference"])
def test_the_floor_is_a_shadow_catcher_whose_alpha_is_the_spheres_shadow(session, renderer):
    """Sun only (no environment light): the floor keeps no colour and its alpha is 1 minus the
    share of sunlight the sphere lets through, so it is opaque where the ray towards the sun
    passes well inside the sphere and clear where it passes well outside. Which is which comes
    from ray geometry here, not from the shader; the margin is the sun disc's penumbra (its
    angular radius times the distance to the sphere) and two pixels. The reference traces the
    floor's light with and without the sphere (direct light only: the share is then its exact
    visibility, 0 or 1 on every path outside the penumbra). Inside the band along the cell's
    border where the catcher fades out (catcher.py) the umbra may be fainter."""
    spec = make_spec(rows=1, cols=1, width=160, height=160, env="black", ibl=False, lights=[SUN],
                     transparent=True)
    if renderer == "chart":
        image = session.render(spec).image
    else:
        from sdfpbr.features.reference import render_reference
        image = render_reference(spec, samples=16, max_bounces=1, seed=4, session=session).image
    r = spec.sphere_radius
    sun = np.asarray(SUN["direction"], float) / np.linalg.norm(SUN["direction"])
    tan_sun = math.tan(math.radians(SUN["angular_radius_deg"]))
    p, pixel, floor = floor_points(spec, np.zeros((1, 3)))
    # The shadow ray from p towards the sun: how close it passes to the sphere's centre.
    s = -(p @ sun)
    passes = np.where(s > 0, np.linalg.norm(p + np.multiply.outer(s, sun), axis=-1), np.linalg.norm(p, axis=-1))
    margin = np.maximum(s, 0) * tan_sun + 2 * pixel
    umbra, lit = floor & (passes < r - margin), floor & (passes > r + margin)
    umbra &= ~fade_band(spec)
    assert umbra.sum() > 100 and lit.sum() > 1000
    alpha, rgb = image[..., 3], image[..., :3]
    assert (alpha[umbra] == 255).all(), np.unique(alpha[umbra])
    assert (alpha[lit] == 0).all(), np.unique(alpha[lit])
    assert (rgb[floor & (alpha > 0)] == 0).all()            # a catcher has no colour of its own


# GLSL's atan of float32 arguments, an allowance: GLSL sets no precision for it, so this is
# llvmpipe's measured error (3.3e-6 rad over [-1, 1], a compute shader against numpy) rounded up
# to 2^-17; a driver with a coarser atan would fail the footprint test below by that alone.
ATAN_RAD = 2.0 ** -17


def fade_band(spec) -> np.ndarray:
    """(H, W) whether a pixel lies in one of its cell's fade bands (catcher.catcher_bands)."""
    g = chart_frame(spec).grid
    left, right, top, bottom = catcher_bands(spec, g)
    x = (np.arange(spec.width) + 0.5 - g.left) % g.cell_width / g.cell_width
    y = (np.arange(spec.height) + 0.5 - g.top) % g.cell_height / g.cell_height
    return np.logical_or.outer((y < top) | (1 - y < bottom), (x < left) | (1 - x < right))


def border_distance(spec) -> np.ndarray:
    """(H, W) pixels from each pixel's centre to the nearest border of its cell."""
    g = chart_frame(spec).grid
    x = (np.arange(spec.width) + 0.5 - g.left) % g.cell_width
    y = (np.arange(spec.height) + 0.5 - g.top) % g.cell_height
    return np.minimum.outer(np.minimum(y, g.cell_height - y), np.minimum(x, g.cell_width - x))


def test_a_shadow_catchers_cells_meet_without_seams(session):
    """Under the default lights and studio a sphere's long soft shadows and occlusion reach its
    cell's border (8-bit alpha 18-25 there, 0 across the seam in the next cell, before the fade):
    the catcher fades out over its band, so across every seam alpha steps by at most 1, the
    grid's outer border and its margins are clear, and the shadows stay (opaque under each
    sphere, partial around it)."""
    spec = make_spec(rows=3, cols=4, width=403, height=307, transparent=True, labels=False)
    alpha = session.render(spec).image[..., 3].astype(int)
    g = chart_frame(spec).grid
    xs = g.left + g.cell_width * np.arange(1, g.cols)      # first column of each cell but the first
    ys = g.top + g.cell_height * np.arange(1, g.rows)
    rows, cols = slice(g.top, g.top + g.rows * g.cell_height), slice(g.left, g.left + g.cols * g.cell_width)
    assert np.abs(alpha[rows, xs] - alpha[rows, xs - 1]).max() <= 1
    assert np.abs(alpha[ys, cols] - alpha[ys - 1, cols]).max() <= 1
    inside = np.zeros(alpha.shape, bool)
    inside[rows, cols] = True
    assert (alpha[~inside] == 0).all() and (alpha[inside & (border_distance(spec) < 1)] <= 1).all()
    band = inside & fade_band(spec)
    assert ((alpha > 0) & (alpha < 255))[band].any()        # faded, not cut
    assert (alpha == 255).any() and ((alpha > 0) & (alpha < 255))[inside & ~band].mean() > 0.1


@pytest.mark.parametrize("stage, rows", [("cells", 1), ("shared", 2)])
def test_without_a_floor_transparency_is_the_spheres_coverage(session, stage, rows):
    """No floor: alpha is the spheres' coverage alone, with partial values on the silhouettes
    (each stage's analytic edge, edge_coverage.glsl)."""
    spec = make_spec(rows=rows, cols=rows, width=96 * rows, height=96 * rows, ground=False, transparent=True,
                     stage=stage)
    alpha = session.render(spec).image[..., 3].astype(float) / 255
    cam = chart_frame(spec).camera
    d = cam.pixel_rays()[1]
    dist = np.full(alpha.shape, np.inf)   # px outside the nearest silhouette: the ray's miss distance
    for c in sphere_centers(spec).reshape(-1, 3) if stage == "shared" else np.zeros((1, 3)):
        along = d @ (c - cam.position)
        miss = np.linalg.norm(cam.position + d * along[..., None] - c, axis=-1)
        dist = np.minimum(dist, (miss - spec.sphere_radius) / (2 * cam.half_height * along / spec.height))
    assert (alpha[dist < -2] == 1).all() and (alpha[dist > 2] == 0).all()
    assert ((alpha > 0) & (alpha < 1))[np.abs(dist) < 1].mean() > 0.5


def test_the_shared_floors_penumbrae_are_each_spheres_share_of_the_sun(session):
    """The shared stage's floor under a wide sun (8 degrees) as a shadow catcher: alpha is the
    share of the sun's disc the spheres hide, integrated here in float64 over 2048 directions
    of the disc (uniform in solid angle) against every sphere of the grid. Where one sphere's
    silhouette meets the disc the chart's two-circle overlap is exact but for treating the
    circles as planar (O(a^2) of the overlap, a = 0.14 rad: 2 %) and the 8-bit alpha (half a
    step): within 0.025. Where two meet, the chart multiplies what each lets through, as if
    their silhouettes fell on the disc independently: off by h1 h2 - h12 (h: the shares each
    hides, h12: the share both hide), within that bound and the 0.025."""
    sun_light = {**SUN, "angular_radius_deg": 8.0}
    spec = make_spec(stage="shared", rows=2, cols=2, width=160, height=160, env="black", ibl=False,
                     lights=[sun_light], transparent=True)
    alpha = session.render(spec).image[..., 3] / 255.0
    centres = sphere_centers(spec).reshape(-1, 3)
    p, _, floor = floor_points(spec, centres)
    sun = np.asarray(sun_light["direction"], float) / np.linalg.norm(sun_light["direction"])
    u = np.cross(sun, [0.0, 0.0, 1.0])
    u /= np.linalg.norm(u)
    v = np.cross(sun, u)
    a = math.radians(sun_light["angular_radius_deg"])
    cos_t = 1 - (np.arange(32) + 0.5) / 32 * (1 - math.cos(a))
    sin_t = np.sqrt(1 - cos_t ** 2)
    phi = (np.arange(64) + 0.5) / 64 * 2 * math.pi
    dirs = (cos_t[:, None, None] * sun + sin_t[:, None, None]
            * (np.cos(phi)[None, :, None] * u + np.sin(phi)[None, :, None] * v)).reshape(-1, 3)
    points = p[floor]
    hits = []
    for c in centres:
        oc = c - points
        along = oc @ dirs.T
        hits.append((along > 0) & ((oc * oc).sum(-1)[:, None] - along ** 2 < spec.sphere_radius ** 2))
    hits = np.array(hits)                                         # (sphere, point, direction)
    want, got = hits.any(0).mean(1), alpha[floor]
    met = hits.any(2)
    one = met.sum(0) <= 1
    assert ((want > 0.05) & (want < 0.95) & one).sum() > 200        # penumbrae, not just umbra and light
    assert np.abs(got - want)[one].max() <= 0.025
    two = met.sum(0) == 2
    pair = np.argsort(~met, axis=0, kind="stable")[:2]              # the two spheres each such point meets
    h1, h2 = (np.take_along_axis(hits.mean(2), pair[k:k + 1], 0)[0] for k in (0, 1))
    rows = np.arange(len(points))
    h12 = (hits[pair[0], rows] & hits[pair[1], rows]).mean(1)
    assert two.sum() > 50
    assert (np.abs(got - want) <= np.abs(h1 * h2 - h12) + 0.025)[two].all()


def _disc_share_hidden(ro: np.ndarray, light: np.ndarray, a: float, radius: float) -> np.ndarray:
    """Float64: the share of a disc light (direction ``light``, angular radius ``a``) that the
    sphere of ``radius`` at the origin hides from each point of ``ro`` -- the overlap of two
    circles in angle (the light's and the sphere's silhouette) over the light's area."""
    dist = np.linalg.norm(ro, axis=-1)
    s = np.arcsin(np.minimum(radius / dist, 1.0))
    g = np.arccos(np.clip((-ro / dist[..., None]) @ light, -1.0, 1.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        lens = (a * a * np.arccos(np.clip((g * g + a * a - s * s) / (2 * g * a), -1, 1))
                + s * s * np.arccos(np.clip((g * g + s * s - a * a) / (2 * g * s), -1, 1))
                - 0.5 * np.sqrt(np.maximum((-g + a + s) * (g + a - s) * (g - a + s) * (g + a + s), 0.0)))
    share = np.where(g >= a + s, 0.0, np.where(g <= s - a, 1.0, lens / (math.pi * a * a)))
    return np.clip(share, 0.0, 1.0)


def test_the_cells_floors_shadow_is_averaged_over_the_pixels_footprint(session):
    """A 1-degree sun's penumbra on the cells floor is narrower than a pixel (its width is the
    disc's angle times the distance to the sphere's silhouette), so the chart averages the
    sun's visible share over the pixel's footprint on the floor: four points of a rotated grid
    (x, y) = (1/8, 3/8), (3/8, -1/8), (-1/8, -3/8), (-3/8, 1/8) of a pixel-wide square across
    the ray, one side level, slid along the ray onto the floor. Mirrored here in float64 from
    the camera's rays and the two circles' overlap, on the floor pixels whose four points do
    not all agree. Bound: the 8-bit alpha's half step, and the two float32 angles the share's
    edge is placed by (g - s, each within ATAN_RAD) through its slope, at most 2 / (pi a) per
    radian across a disc of angular radius a (36 at 1 degree; the shader's angles come from
    atan, not asin and acos, which llvmpipe evaluates to 4e-4 rad)."""
    spec = make_spec(rows=1, cols=1, width=160, height=160, env="black", ibl=False, lights=[SUN],
                     transparent=True)
    alpha = session.render(spec).image[..., 3] / 255.0
    r = spec.sphere_radius
    a = math.radians(SUN["angular_radius_deg"])
    sun = np.asarray(SUN["direction"], float) / np.linalg.norm(SUN["direction"])
    p, pixel, floor = floor_points(spec, np.zeros((1, 3)))
    floor &= ~fade_band(spec)
    lifted = p + [0.0, 1e-3 * r, 0.0]
    hidden = np.stack([_disc_share_hidden(lifted + o, sun, a, r) for o in footprint_offsets(spec, p, pixel)])
    split = floor & (hidden.min(0) < hidden.max(0))   # the penumbra crosses the footprint
    assert split.sum() > 100
    want = hidden.mean(0)
    assert ((want > 0.1) & (want < 0.9) & split).sum() > 50   # a pixel's share, not the centre's 0 or 1
    bound = 0.5 / 255 + 2 * ATAN_RAD * 2 / (math.pi * a)
    assert np.abs(alpha - want)[split].max() <= bound, np.abs(alpha - want)[split].max()
