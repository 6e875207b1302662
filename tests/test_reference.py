"""The path-traced reference against closed forms and float64 integrals (sdfpbr.oracle.shading_model).

Expected pixel values are integrated here independently of the renderer: primary rays are
re-traced in numpy at 6 x 6 points per pixel (the reference averages over the pixel), and
the BRDF integrals come from the float64 model. Tolerances are k standard errors of the
reference's own per-pixel estimate plus a stated bias bound."""
import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from sdfpbr.errors import SpecError
from sdfpbr.oracle import shading_model
from sdfpbr.shading.camera import sphere_centers
from sdfpbr.features.reference import batch_size, integrator, render_reference
from sdfpbr.spec.chart_spec import Light, make_spec

from helpers import BIAS, SUB, check_converged, interior, luminance, primary_hits, table_bias
from helpers import REFERENCE_FURNACE as FURNACE

# These tests trace the shared stage's grid camera in float64 (primary_hits); the cells stage
# has its own in test_reference_cells.py.
SHARED = dict(stage="shared")

def furnace_curve(mu, metallic, roughness, multiscatter):
    """Directional albedo of the white material under the uniform environment (docs/model.md,
    §2-3, float64), interpolated from a dense NdotV grid (spacing 2e-3: error < 1e-6)."""
    grid = np.linspace(0.0, 1.0, 513)
    albedo = shading_model.furnace_expected(grid, np.ones(3), metallic, roughness, multiscatter=multiscatter)[:, 0]
    return np.interp(mu, grid, albedo)


@pytest.mark.parametrize("metallic, roughness, multiscatter", [
    (1.0, 0.3, True), (1.0, 0.7, False), (0.0, 0.5, True), (0.0, 0.2, False)])
def test_uniform_environment_converges_to_directional_albedo(session, metallic, roughness, multiscatter):
    """max_bounces = 1 on a lone sphere: each pixel integrates f cos over the hemisphere, i.e.
    the directional albedo at its NdotV (1 for a compensated white metal)."""
    spec = make_spec(**FURNACE, roughness=(roughness, roughness), metallic=(metallic, metallic),
                     multiscatter=multiscatter)
    res = render_reference(spec, samples=256, max_bounces=1, seed=1, session=session)
    hits = primary_hits(spec)
    m = interior(spec, hits, 0.15)
    assert m.sum() > 500 and res.non_finite == 0
    ndotv = (hits[3] * hits[4]).sum(-1)
    want = furnace_curve(ndotv, metallic, roughness, multiscatter).mean(-1)
    check_converged(luminance(res.hdr)[m], want[m], res.stderr[m],
                    bias=table_bias(session, spec, hits, want)[m] if multiscatter else BIAS)
    np.testing.assert_array_equal(res.hdr[..., 0], res.hdr[..., 2])   # white stays white
    if metallic == 1.0 and multiscatter:
        np.testing.assert_allclose(want[m], 1.0, atol=1e-9)   # docs/model.md, the white furnace: the sphere vanishes


def test_white_lambert_sphere_converges_to_its_albedo(session):
    for albedo in (1.0, 0.5):
        spec = make_spec(**{**FURNACE, "base_color": (albedo,) * 3})
        res = render_reference(spec, samples=128, max_bounces=4, seed=2, session=session, lambert=True)
        m = interior(spec, primary_hits(spec), 0.05)
        check_converged(res.hdr[..., 1][m], np.full(m.sum(), albedo), res.stderr[m])


def test_interreflection_between_white_lambert_spheres_conserves_energy(session):
    """Two white Lambert spheres in a white furnace: with enough bounces every pixel reads 1
    (light only changes direction); with direct light only, the faces that see the other
    sphere go dark. A path survives 12 bounces between them with probability < 1e-10."""
    spec = make_spec(**{**FURNACE, "cols": 2, "spacing": 2.2, "width": 64, "height": 32})
    m = interior(spec, primary_hits(spec), 0.05)
    full = render_reference(spec, samples=96, max_bounces=12, seed=3, session=session, lambert=True)
    check_converged(full.hdr[..., 1][m], np.ones(m.sum()), full.stderr[m])
    direct = render_reference(spec, samples=32, max_bounces=1, seed=3, session=session, lambert=True)
    assert direct.hdr[..., 1][m].min() < 0.85


def test_same_seed_is_bit_identical_and_another_seed_is_not(session):
    spec = make_spec(width=32, height=32, **SHARED)   # the default scene: ground, sun, point light, studio
    a = render_reference(spec, samples=6, seed=7, session=session)
    b = render_reference(spec, samples=6, seed=7, session=session)
    c = render_reference(spec, samples=6, seed=8, session=session)
    assert np.array_equal(a.hdr, b.hdr) and np.array_equal(a.stderr, b.stderr, equal_nan=True)
    assert np.array_equal(a.image, b.image)
    assert not np.array_equal(a.hdr, c.hdr)
    assert np.abs(a.hdr - c.hdr).mean() > 1e-3 * a.hdr.mean()
    assert a.non_finite == 0 and np.isfinite(a.hdr).all()


@pytest.mark.parametrize("scene", [dict(width=32, height=32, **SHARED),
                                   dict(width=24, height=24, rows=2, cols=2, transparent=True)],
                         ids=["shared", "cells-shadow-catcher"])
def test_a_resumed_run_equals_the_straight_run_bit_for_bit(session, scene):
    """More samples for a finished reference go on from its accumulators: 3 then 7 more (a
    batch boundary the straight run does not have) gives the straight 10-sample run's bits,
    shadow catcher included."""
    spec = make_spec(**scene)
    straight = render_reference(spec, samples=10, seed=11, session=session)
    first = render_reference(spec, samples=3, seed=11, session=session)
    assert first.accumulators.samples == 3 and not np.array_equal(first.hdr, straight.hdr)
    assert (first.accumulators.catcher is not None) == spec.transparent
    resumed = render_reference(spec, samples=10, seed=11, session=session, resume=first.accumulators)
    assert resumed.samples == 10
    for name in ("hdr", "alpha", "stderr", "image"):
        assert np.array_equal(getattr(resumed, name), getattr(straight, name), equal_nan=True), name


# The heaviest reference found: 100 mirrors under 16 lights, each path up to 64 bounces.
LONG_PATHS = dict(width=32, height=32, rows=10, cols=10, base_color=(1.0, 1.0, 1.0), metallic=1.0,
                  roughness=(0.0, 0.3), lights=tuple(Light("directional",
                                                           direction=(np.cos(0.39 * k), 0.6, np.sin(0.39 * k)),
                                                           intensity=0.3, angular_radius_deg=3.0) for k in range(16)),
                  **SHARED)


@pytest.mark.parametrize("per_dispatch", [64, 128])
def test_samples_the_loop_limit_cuts_short_are_drawn_again_to_the_same_bits(session, monkeypatch, per_dispatch):
    """llvmpipe ends every loop of an invocation, silently, once they have turned 65535 times
    (gpu/loop_guard.py). Here 64 samples a dispatch (32²'s batch) lost 7 % of the light and 128
    lost 46 %: a reference silently wrong. Now an invocation cut short stores nothing and its
    samples are drawn again, fewer a dispatch, so the run equals the run of one sample a
    dispatch bit for bit (a pixel's sums take its samples in order either way; a GPU has no
    such limit)."""
    spec = make_spec(**LONG_PATHS)
    runs = {}
    for n in (1, per_dispatch):
        monkeypatch.setattr(integrator, "batch_size", lambda w, h, n=n: n)
        runs[n] = render_reference(spec, samples=128, seed=3, session=session, max_bounces=64)
    for name in ("hdr", "alpha", "stderr"):
        assert np.array_equal(getattr(runs[per_dispatch], name), getattr(runs[1], name), equal_nan=True), name


def test_resume_needs_the_same_run_with_fewer_samples(session):
    """Accumulators go on only in their own run (scene, seed, bounces, lambert flag): any other
    would mix two sample sequences into one silently wrong mean."""
    spec = make_spec(width=16, height=16, **SHARED)
    state = render_reference(spec, samples=4, seed=1, session=session).accumulators
    with pytest.raises(SpecError, match="more samples than its 4"):
        render_reference(spec, samples=4, seed=1, session=session, resume=state)
    for other in (dict(seed=2), dict(max_bounces=2), dict(lambert=True)):
        with pytest.raises(SpecError, match="another run's"):
            render_reference(spec, samples=8, session=session, resume=state, **{"seed": 1, **other})
    for changed in (dict(width=8), dict(roughness=0.3), dict(env="sky")):
        with pytest.raises(SpecError, match="another run's"):
            render_reference(make_spec(**{"width": 16, "height": 16, **SHARED, **changed}), samples=8, seed=1,
                             session=session, resume=state)
    with pytest.raises(SpecError, match="not to a target error"):
        render_reference(spec, target_error=0.1, session=session, resume=state)
    cut = dataclasses.replace(state, sums=state.sums[:8])   # its own run's name on arrays of another size
    with pytest.raises(SpecError, match="not 16x16 RGBA"):
        render_reference(spec, samples=8, seed=1, session=session, resume=cut)
    # What does not change the pixels does not change the run.
    render_reference(make_spec(width=16, height=16, quality="high", title="x", **SHARED), samples=5, seed=1,
                     session=session, resume=state)


def test_stderr_shrinks_as_one_over_sqrt_n_and_is_honest(session):
    """A pixel's stderr is its samples' spread / sqrt(n), as if they were independent. Its pixel
    positions are stratified, which can remove at most the variance of the float64 value over
    the pixel (Var_pos / n) from the estimate's true error, so over pixels and seeds the squared
    error against the float64 albedo must fall between mean(stderr^2) - Var_pos / n and
    mean(stderr^2), within 5 standard deviations of those means (chi-square: sqrt(2 / count))."""
    spec = make_spec(**FURNACE, roughness=(0.5, 0.5), metallic=(0.0, 0.0))
    hits = primary_hits(spec)
    m = interior(spec, hits, 0.15)
    want_sub = furnace_curve((hits[3] * hits[4]).sum(-1), 0.0, 0.5, True)[m]    # (pixels, subsamples)
    want, var_pos = want_sub.mean(-1), want_sub.var(-1)
    variance, variance_noise = {}, {}
    for n in (16, 64):
        runs = [render_reference(spec, samples=n, max_bounces=1, seed=seed, session=session) for seed in (4, 5, 6, 7)]
        got = np.array([r.hdr[..., 0][m] for r in runs], float)
        se2 = np.array([r.stderr[m] for r in runs], float) ** 2
        count = got.size
        squared_error, expected = np.mean((got - want) ** 2), np.mean(se2)
        # Relative standard deviations of the two means: a squared Gaussian error's is sqrt(2 /
        # count); the stderr^2's is read from its own spread over the pixels.
        variance_noise[n] = np.std(se2) / expected / np.sqrt(count)
        noise = 5 * np.hypot(np.sqrt(2 / count), variance_noise[n])
        assert expected * (1 - noise) - np.mean(var_pos) / n <= squared_error <= expected * (1 + noise), \
            (n, squared_error / expected)
        # No bias: the mean over pixels and seeds within 4 of its standard errors plus the bound.
        assert abs((got - want).mean()) <= 4 * np.sqrt(se2.sum()) / count + BIAS * want.mean()
        variance[n] = expected
    # 64 samples hold a quarter of 16's variance (the root mean square stderr: half); the ratio
    # of the two means varies by their relative deviations, halved under the square root.
    ratio = np.sqrt(variance[16] / variance[64])
    assert abs(ratio / 2 - 1) <= 5 * 0.5 * np.hypot(variance_noise[16], variance_noise[64]), ratio


def test_target_error_stops_early_and_reports_what_it_reached(session):
    spec = make_spec(**FURNACE, roughness=(0.5, 0.5), metallic=(1.0, 1.0))
    res = render_reference(spec, target_error=0.01, samples=4096, max_bounces=1, seed=5, session=session)
    assert res.error <= 0.01 and res.samples < 4096
    assert res.samples % batch_size(spec.width, spec.height) == 0
    m = res.aov["row"] >= 0
    rel = res.stderr[m] / np.maximum(res.hdr[m] @ [0.2126, 0.7152, 0.0722], 1e-12)
    assert rel.mean() == pytest.approx(res.error, rel=1e-3)


def cone_average(f, axis, theta, rings=3, spokes=8):
    """Mean of f(l) over directions uniform in the cone (midpoint rule in (1 - cos) and phi)."""
    t = np.cross(axis, [0.0, 0.0, 1.0])
    t /= np.linalg.norm(t)
    b = np.cross(axis, t)
    total = 0.0
    for i in range(rings):
        omc = (i + 0.5) / rings * (1 - np.cos(theta))
        sin_t = np.sqrt(omc * (2 - omc))
        for k in range(spokes):
            phi = 2 * np.pi * (k + 0.5) / spokes
            total = total + f((1 - omc) * axis + sin_t * (np.cos(phi) * t + np.sin(phi) * b))
    return total / (rings * spokes)


def test_small_sun_converges_to_closed_form(session):
    """Black environment, no ground, one sun of angular radius 0.25 deg, direct light only:
    a pixel reads the disc's radiance E / (pi sin^2) integrated over the disc,
    E 2 / (1 + cos theta) x mean over the disc of f(v, l) NdotL, from the float64 BRDF."""
    sun_dir = np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8])
    theta_deg, illuminance = 0.25, 2.0
    sun = Light("directional", direction=tuple(sun_dir), intensity=illuminance, angular_radius_deg=theta_deg)
    base = np.array([0.9, 0.6, 0.3])
    spec = make_spec(**SHARED, env="black", lights=(sun,), ground=False, rows=2, cols=2, roughness=(0.4, 0.8),
                     metallic=(0.0, 1.0), base_color=tuple(base), multiscatter=False, width=48, height=48)
    res = render_reference(spec, samples=64, max_bounces=1, seed=6, session=session)
    theta = np.radians(theta_deg)

    def expected(sub, rings=3, spokes=8):
        """Pixels whose subsamples all see the sun unshadowed at NdotV >= 0.1, and their value."""
        hits = primary_hits(spec, sub)
        hit, row, col, normal, view = hits
        m = interior(spec, hits, 0.1)
        # Keep pixels no other sphere shadows (the light comes from the camera side; this checks it).
        centers = sphere_centers(spec)
        p = centers[np.maximum(row, 0), np.maximum(col, 0)] + normal * spec.sphere_radius
        for j in range(spec.rows):
            for i in range(spec.cols):
                rel = centers[j, i] - p
                along = rel @ sun_dir
                miss = np.linalg.norm(rel - along[..., None] * sun_dir, axis=-1)
                other = (row != j) | (col != i)
                m &= ~((other & (along > 0) & (miss < 1.05 * spec.sphere_radius)).any(-1))
        metallic = spec.material_array("metallic")[np.maximum(row, 0), np.maximum(col, 0)]
        roughness = spec.material_array("roughness")[np.maximum(row, 0), np.maximum(col, 0)]

        def f_cos(l):
            l = np.broadcast_to(l, normal.shape)
            cos = np.clip((normal * l).sum(-1), 0, None)[..., None]
            return shading_model.brdf(normal, view, l, base, metallic, roughness) * cos

        disc = illuminance * 2 / (1 + np.cos(theta)) * cone_average(f_cos, sun_dir, theta, rings, spokes).mean(-2)
        return m, disc, illuminance * f_cos(sun_dir).mean(-2)

    # The expected value at 12 x 12 points a pixel; its quadrature error is bounded by how far it
    # moved from 6 x 6 (the midpoint rule converges as h^2 where the pixel is smooth), and the
    # disc's 3 x 8 rule by how far 6 x 16 moves it; float32 sums add ~1e-5.
    m, want, point = expected(2 * SUB)
    m6, want6, _ = expected(SUB)
    _, want_fine, _ = expected(SUB, rings=6, spokes=16)
    lit = m & m6 & (luminance(want) > 1e-3)
    assert lit.sum() > 300
    off = (np.abs(want - want6) + np.abs(want6 - want_fine))[lit]                 # (pixels, 3), absolute
    check_converged(luminance(res.hdr)[lit], luminance(want)[lit], res.stderr[lit],
                    bias=luminance(off) / luminance(want[lit]) + 1e-5)
    # Per channel, the luminance error scaled by the channel's share (the noise here is in
    # magnitude: where on the disc and in the pixel a sample falls, not in colour).
    share = want[lit] / luminance(want)[lit][:, None]
    for channel in range(3):
        check_converged(res.hdr[lit][:, channel], want[lit][:, channel], res.stderr[lit] * share[:, channel],
                        bias=off[:, channel] / want[lit][:, channel] + 1e-5)
    # The same pixels with the sun's centre direction only: the disc changes them by less than 1 %.
    np.testing.assert_allclose(point[lit], want[lit], rtol=1e-2, atol=1e-4)


@pytest.mark.parametrize("grid", [
    dict(rows=3, cols=4, camera_azimuth=20.0),
    dict(rows=3, cols=3, spacing=1.6, camera_elevation=35.0),   # overlapping spheres
    dict(rows=10, cols=10, camera="orthographic"),
])
def test_aovs_match_the_chart(session, grid):
    """The reference traces the chart's scene: same cells, normals and NdotV per pixel."""
    spec = make_spec(width=64, height=48, **SHARED, **grid)
    ref = render_reference(spec, samples=1, session=session)
    chart = session.render(spec)
    same = (ref.aov["row"] == chart.aov["row"]) & (ref.aov["col"] == chart.aov["col"])
    assert same.mean() > 0.995 and set(ref.aov) == set(chart.aov)
    sphere = same & (ref.aov["row"] >= 0)
    np.testing.assert_allclose(ref.aov["normal"][sphere], chart.aov["normal"][sphere], atol=1e-4)
    np.testing.assert_allclose(ref.aov["ndotv"][sphere], chart.aov["ndotv"][sphere], atol=1e-4)


def run_cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "sdfpbr", "reference", *args], capture_output=True,
                          text=True, cwd=cwd)


def test_cli_writes_png_hdr_and_aov(tmp_path, cache_dir):
    r = run_cli("--size", "32x32", "--samples", "4", "-o", "x.png", "--hdr", "x.npy", "--aov", "x.npz",
                cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    hdr = np.load(tmp_path / "x.npy")
    assert hdr.shape == (32, 32, 3) and hdr.dtype == np.float32 and np.isfinite(hdr).all()
    aov = np.load(tmp_path / "x.npz")
    assert {"normal", "depth", "row", "col", "roughness", "metallic", "ndotv", "stderr"} <= set(aov.files)
    from PIL import Image
    png = Image.open(tmp_path / "x.png")
    assert png.width > 32 and "sdfpbr:reference" in png.info


@pytest.mark.parametrize("args, needle", [
    (["--samples", "0"], "samples must be"),
    (["--target-error", "0"], "target error"),
    (["--bounces", "0"], "bounces must be"),
    (["--seed", "-3"], "seed must be"),
    (["--hdr", "x.txt"], ".npy or .exr"),
])
def test_cli_bad_arguments_are_one_line_exit_2_no_file(tmp_path, args, needle):
    r = run_cli("--size", "32x32", *args, "-o", "x.png", cwd=tmp_path)
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and needle in r.stderr and "Traceback" not in r.stderr
    assert not list(tmp_path.iterdir())
