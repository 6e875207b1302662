"""Rendered charts against properties derived independently of the renderer."""
import numpy as np
import pytest

from sdfpbr.oracle import shading_model
from sdfpbr.shading.plan import chart_frame, render_plan
from sdfpbr.spec.chart_spec import Light, make_spec

from helpers import FurnaceBudget

# Point-sampled (no anti-aliasing): each pixel is its centre's shading, which the oracles
# evaluate at the pixel's AOVs (anti-aliased, a small sphere's pixel averages its box).
FURNACE = dict(env="uniform", lights="none", shadows=False, ao=False, ground=False, base_color=(1.0, 1.0, 1.0),
               width=256, height=256, antialias=False)


def _interior(res, min_ndotv=0.15):
    """Sphere pixels away from silhouettes (where a pixel mixes sphere and background)."""
    return (res.aov["row"] >= 0) & (res.aov["ndotv"] > min_ndotv) & (res.aov["coverage"] >= 1.0)


@pytest.mark.parametrize("multiscatter", [True, False])
def test_furnace_metal_row_matches_reference(session, multiscatter):
    spec = make_spec(**FURNACE, multiscatter=multiscatter)
    res = session.render(spec)
    m = _interior(res) & (res.aov["metallic"] == 1.0)
    budget = FurnaceBudget(session, spec, res, m)
    budget.check()
    if multiscatter:   # docs/model.md, the white furnace: a compensated white metal vanishes into the background
        np.testing.assert_allclose(budget.got, 1.0, atol=1e-5)
    else:              # reads E(mu, r), the float64 directional albedo
        assert budget.got[:, 0].min() < 0.5            # the loss is visible at r = 1


def test_furnace_every_row_matches_split_sum_expectation(session):
    spec = make_spec(**FURNACE)
    res = session.render(spec)
    budget = FurnaceBudget(session, spec, res, _interior(res))
    budget.check()
    assert budget.texel_error > 0 and budget.interpolation.max() > 0   # both budgets are real


def test_direct_light_matches_mirror_per_pixel(session):
    """Black environment, one directional light of zero size: every sphere pixel equals
    f(v, l) cos E from the float64 model, evaluated with the pixel's own normal, the light
    shaded as the disc of reflected directions the pixel sweeps (shaded_light_angle; the
    orthographic camera's pixel is one size everywhere)."""
    light = Light("directional", direction=(0.6, 0.5, 0.62), intensity=2.0)
    spec = make_spec(env="black", lights=(light,), shadows=False, ao=False, ground=False, ibl=False,
                     multiscatter=False, camera="orthographic", width=192, height=192, rows=3, cols=4,
                     base_color=(0.8, 0.5, 0.2), antialias=False)
    res = session.render(spec)
    m = _interior(res, 0.05)
    n = res.aov["normal"][m].astype(float)
    v = np.broadcast_to(-res.camera.forward, n.shape)
    l = np.broadcast_to(np.array(light.direction), n.shape)
    disc = shading_model.shaded_light_angle(0.0, res.camera.pixel_size(), spec.sphere_radius)
    want = shading_model.brdf(n, v, l, np.array(spec.base_color), res.aov["metallic"][m].astype(float),
                              res.aov["roughness"][m].astype(float), disc_angular_radius=disc) \
        * np.clip((n * l).sum(1), 0, None)[:, None] * 2.0
    np.testing.assert_allclose(res.hdr[m], want, rtol=5e-3, atol=2e-4)


def test_a_small_spheres_pixels_average_points_each_spread_over_its_share(session):
    """Spheres a few pixels wide, anti-aliased: each inside pixel is the mean of the n x n
    points of its box (SPHERE_SAMPLES) whose rays meet the sphere, each shading the light as the
    disc its own share of the pixel sweeps (pixel / n; shaded_light_angle). The float64 model
    traces the same points to the sphere and shades them the same way."""
    light = Light("directional", direction=(0.3, 0.45, 0.84), intensity=2.0)
    spec = make_spec(env="black", lights=(light,), shadows=False, ao=False, ground=False, ibl=False,
                     multiscatter=False, camera="orthographic", stage="shared", width=48, height=48,
                     rows=2, cols=2, roughness=(0.0, 0.3), metallic=(1.0, 0.0), base_color=(0.8, 0.5, 0.2))
    n = dict(render_plan(spec).chart.options).get("SPHERE_SAMPLES", 1)
    assert n > 1   # the claim needs the averaged pixels
    res = session.render(spec)
    m = _interior(res, 0.05)
    ys, xs = np.nonzero(m)
    offsets = (np.arange(n) + 0.5) / n
    grid = (len(xs), n, n)
    sub_x = np.broadcast_to(xs[:, None, None] + offsets[None, None, :], grid).reshape(len(xs), -1)
    sub_y = np.broadcast_to(ys[:, None, None] + offsets[None, :, None], grid).reshape(len(ys), -1)
    cam = res.camera
    ro, rd = cam.rays(2 * sub_x / cam.width - 1, 1 - 2 * sub_y / cam.height)
    rows, cols = res.aov["row"][m].astype(int), res.aov["col"][m].astype(int)
    centre = chart_frame(spec).sphere_centers[rows, cols][:, None, :]
    oc = ro - centre
    b = (oc * rd).sum(-1)
    disc = b * b - ((oc * oc).sum(-1) - spec.sphere_radius ** 2)
    hit = disc >= 0
    normal = shading_model.normalize(oc - rd * (b + np.sqrt(np.maximum(disc, 0)))[..., None])
    l = np.broadcast_to(np.array(light.direction), normal.shape)
    rough = spec.material_array("roughness")[rows, cols][:, None]
    metal = spec.material_array("metallic")[rows, cols][:, None]

    def pixels(share):
        angle = shading_model.shaded_light_angle(0.0, share * cam.pixel_size(), spec.sphere_radius)
        f = shading_model.brdf(normal, -rd, l, np.array(spec.base_color), metal, rough, disc_angular_radius=angle)
        radiance = f * np.clip((normal * l).sum(-1), 0, None)[..., None] * light.intensity * hit[..., None]
        return radiance.sum(1) / hit.sum(1)[:, None]

    np.testing.assert_allclose(res.hdr[m], pixels(1.0 / n), rtol=5e-3, atol=2e-4)
    assert render_plan(spec).glint_share == 1.0 / n   # the plan says what the GLSL shades by
    # Spread over the whole pixel instead, the polished sphere's highlight is another image.
    assert np.abs(pixels(1.0) - pixels(1.0 / n)).max() > 0.1


def test_metal_row_has_no_diffuse_under_back_light(session):
    """Where the float64 model puts no specular energy but a Lambert body would be lit, the
    metal row is black and the dielectric row is not."""
    light = Light("directional", direction=(-0.8, 0.3, -0.52), intensity=3.0)   # behind, to the left
    spec = make_spec(env="black", lights=(light,), shadows=False, ao=False, ground=False, ibl=False,
                     camera="orthographic", rows=2, cols=3, metallic=(0, 1), roughness=(0.2, 0.3),
                     width=240, height=160, base_color=(1.0, 1.0, 1.0))
    res = session.render(spec)
    m = _interior(res, 0.1)
    n = res.aov["normal"][m].astype(float)
    v = np.broadcast_to(-res.camera.forward, n.shape)
    l = np.broadcast_to(np.array(light.direction), n.shape)
    cos = np.clip((n * l).sum(1), 0, None)
    specular_only = shading_model.brdf(n, v, l, np.ones(3), 1.0,
                                       res.aov["roughness"][m].astype(float))[:, 0] * cos * 3.0
    lambert = cos / np.pi * 3.0
    quiet = (specular_only < 2e-3) & (lambert > 0.1)
    rows = res.aov["row"][m]
    dielectric, metal = (res.hdr[m][quiet & (rows == row)] for row in (0, 1))
    assert len(dielectric) > 10 and len(metal) > 10
    assert dielectric.mean() > 0.1                   # the Lambert body catches the back light
    assert metal.mean() < 0.05 * dielectric.mean()   # a metal has no body


def test_highlight_narrows_and_brightens_towards_smooth(session):
    light = Light("directional", direction=(0.3, 0.4, 0.87), intensity=3.0)
    spec = make_spec(env="black", lights=(light,), shadows=False, ao=False, ground=False, ibl=False,
                     rows=1, cols=5, roughness=(0.15, 0.95), metallic=(1, 1), width=500, height=120,
                     camera="orthographic")
    res = session.render(spec)
    peaks, areas = [], []
    for col in range(5):
        m = res.aov["col"] == col
        lum = res.hdr[m].mean(1)
        peaks.append(lum.max())
        areas.append((lum > 0.5 * lum.max()).sum())
    assert all(a > b for a, b in zip(peaks, peaks[1:])), peaks
    assert all(a < b for a, b in zip(areas, areas[1:])), areas


def test_aov_ndotv_matches_normals_and_view(session):
    res = session.render(make_spec(width=160, height=160, rows=2, cols=2, stage="shared"))   # one camera
    m = res.aov["row"] >= 0
    h, w = res.hdr.shape[:2]
    ys, xs = np.nonzero(m)
    ndc = np.stack([2 * (xs + 0.5) / w - 1, 1 - 2 * (ys + 0.5) / h], 1)
    cam = res.camera
    rd = cam.forward + (ndc[:, :1] * w / h * cam.half_height) * cam.right + (ndc[:, 1:] * cam.half_height) * cam.up
    rd /= np.linalg.norm(rd, axis=1, keepdims=True)
    n = res.aov["normal"][m]
    np.testing.assert_allclose(res.aov["ndotv"][m], -(n * rd).sum(1), atol=1e-4)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)
    # The hit point lies on the sphere of its cell.
    from sdfpbr.shading.camera import sphere_centers
    p = cam.position + rd * res.aov["depth"][m][:, None]
    c = sphere_centers(res_spec := make_spec(width=160, height=160, rows=2, cols=2,
                                             stage="shared"))[res.aov["row"][m], res.aov["col"][m]]
    np.testing.assert_allclose(np.linalg.norm(p - c, axis=1), res_spec.sphere_radius, atol=1e-3)
    assert np.isinf(res.aov["depth"][res.aov["ndotv"] == -1]).all()


def test_marched_and_analytic_paths_agree(session):
    """The marcher stops at the first point within eps = hit_scale x the pixel footprint of the
    sphere and takes a tetrahedron normal there with step e = the footprint; both errors have
    closed forms, so every pixel's normal is held to its own bound (the shading that follows a
    normal is checked under the furnace, test_furnace_every_row_matches_split_sum_expectation)."""
    base = dict(width=200, height=200, rows=3, cols=3)
    a = session.render(make_spec(**base, intersect="analytic"))
    spec = make_spec(**base, intersect="march")
    b = session.render(spec)
    quality, cam, r = b.frame.quality, b.camera, spec.sphere_radius
    pixel = 2 * cam.half_height / cam.height                 # footprint per unit distance (camera.glsl)
    assert not cam.orthographic and quality.normal_method == "tetrahedron"   # the forms below are theirs
    # The tetrahedron normal at step e: its second-order term turns the normal by
    # e / r |(nynz, nxnz, nxny)| <= e / (r sqrt 3), its third-order term by at most 4.5 (e / r)^2.
    def tetrahedron(t):
        e = np.maximum(pixel * t, 1e-4 * r)
        return e / (r * np.sqrt(3)) + 4.5 * (e / r) ** 2

    # Where the paths see different cells, the marcher hit the shell |p - c| - r < eps of a sphere
    # the ray misses (or grazes before the one it hits): there NdotV <= sqrt((r + eps)^2 - r^2) / r,
    # plus its normal's error. It never misses a sphere the analytic path hits (that would be a hole).
    hit_a, hit_b = a.aov["row"] >= 0, b.aov["row"] >= 0
    differ = (a.aov["row"] != b.aov["row"]) | (a.aov["col"] != b.aov["col"])
    assert (hit_b | ~hit_a).all()
    t_b = np.where(hit_b, b.aov["depth"], 0.0)
    eps_b = quality.hit_scale * pixel * t_b + quality.hit_epsilon
    shell = np.sqrt(2 * eps_b / r + (eps_b / r) ** 2) + tetrahedron(t_b)
    assert differ.any() and (b.aov["ndotv"][differ] <= shell[differ] + 1e-4).all()
    # Same sphere: the marched point lies s before the analytic one on the same ray, with
    # s^2 + 2 r s mu = 2 r eps + eps^2 at most, which turns the normal by atan(s sin / (r + s mu)),
    # then the tetrahedron's error. eps and e grow with t: the analytic t bounds both.
    m = ~differ & hit_a & (a.aov["ndotv"] > 0.05)
    mu, t = a.aov["ndotv"][m].astype(float), a.aov["depth"][m].astype(float)
    eps = quality.hit_scale * pixel * t + quality.hit_epsilon
    s = -r * mu + np.sqrt((r * mu) ** 2 + 2 * r * eps + eps ** 2)
    bound = np.arctan2(s * np.sqrt(1 - mu ** 2), r + s * mu) + tetrahedron(t)
    na, nb = a.aov["normal"][m].astype(float), b.aov["normal"][m].astype(float)
    angle = np.arccos(np.clip((na * nb).sum(1), -1, 1))
    assert (angle <= bound + 1e-4).all(), (angle / bound).max()   # 1e-4: float32 normals and sums
    assert np.median(angle) > 1e-4      # the marched normals are the marcher's own, beyond rounding


def test_no_nan_or_inf_at_the_edges(session):
    spec = make_spec(width=128, height=128, roughness=(0, 1), metallic=(0, 1), rows=3, cols=3, spp=2,
                     base_color=(0, 0, 0))
    for s in (spec, make_spec(spec, base_color=(1, 1, 1), brdf="schlick-ggx"), make_spec(spec, multiscatter=False)):
        res = session.render(s)
        assert np.isfinite(res.hdr).all() and res.hdr.min() >= 0


def test_same_spec_same_pixels(session):
    spec = make_spec(width=96, height=96, spp=2)
    assert np.array_equal(session.render(spec).image, session.render(spec).image)


@pytest.mark.requires_backend("osmesa")
def test_osmesa_backend_renders_the_same_chart(session, osmesa_session):
    spec = make_spec(width=96, height=96, rows=2, cols=2)
    a, b = session.render(spec), osmesa_session.render(spec)
    assert osmesa_session.ctx.extra["backend"] == "osmesa"
    assert np.abs(a.image.astype(int) - b.image.astype(int)).max() <= 1


def test_transparent_background_has_zero_alpha(session):
    """Alpha is the spheres' coverage of the pixel: 0 off them, 255 inside, and at the
    anti-aliased silhouette the covered share (within an 8-bit step)."""
    res = session.render(make_spec(width=96, height=96, transparent=True, ground=False))
    alpha, coverage = res.image[..., 3].astype(float), res.aov["coverage"]
    assert res.image[0, 0, 3] == 0 and (alpha[coverage == 0] == 0).all()
    assert (alpha[coverage == 1] == 255).all()
    edge = (coverage > 0) & (coverage < 1)
    assert edge.sum() > 100   # every silhouette pixel
    assert np.abs(alpha[edge] - 255 * coverage[edge]).max() <= 1.0


def test_ibl_cache_on_disk_reproduces_the_bake(session, cache_dir):
    from sdfpbr.cache import ArrayCache
    from sdfpbr.gpu.gl import create_context
    from sdfpbr.gpu.session import Session
    spec = make_spec(width=64, height=64, env="sky")
    first = session.render(spec)
    assert any((cache_dir / "ibl").glob("*.npz"))
    fresh = Session(create_context("egl"), ArrayCache(cache_dir))
    again = fresh.render(spec)   # loads from disk
    fresh.release()   # its context, not left to the worker
    assert np.array_equal(first.image, again.image)
