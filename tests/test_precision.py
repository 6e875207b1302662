"""Half precision: where the BRDF formulas break in float16 (the numpy model evaluated with
every operation rounded to half), each boundary derived in closed form from the half-float
format (max 65504, smallest normal 2^-14, smallest subnormal 2^-24); and the renderer's
half-float radiance targets, which stay finite because the chart program clamps them."""
import math
import warnings

import numpy as np
import pytest

from sdfpbr.oracle import display, shading_model
from sdfpbr.shading.plan import render_plan
from sdfpbr.spec.chart_spec import Light, make_spec

HALF = np.float16
HALF_MAX = float(np.finfo(HALF).max)            # 65504
HALF_NORMAL_MIN = float(np.finfo(HALF).tiny)    # 2^-14
ROUGHNESS_GRID = np.round(np.arange(0.010, 1.0, 0.0025), 6)


@pytest.fixture(autouse=True)
def _quiet_overflow():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)   # overflow is what these tests look at
        yield


def _rel(a, b):
    return abs(float(a) / float(b) - 1.0)


def test_the_mirror_keeps_float64_by_default():
    r = np.linspace(0.05, 1, 7)
    assert shading_model.d_ggx(0.9, r * r).dtype == np.float64
    assert shading_model.d_ggx(0.9, r * r, dtype=HALF).dtype == HALF
    np.testing.assert_allclose(shading_model.d_ggx_half_safe(np.linspace(0, 1, 50)[:, None], r * r),
                               shading_model.d_ggx(np.linspace(0, 1, 50)[:, None], r * r), rtol=1e-12)


def test_filament_fp16_roughness_keeps_alpha_squared_a_normal_half():
    """docs/model.md, conventions: 0.089 is the smallest perceptual roughness (to 3 digits) whose alpha^2 =
    r^4 is a normal half; 0.045, the fp32 clamp, lands deep in the subnormals."""
    r_star = HALF_NORMAL_MIN ** 0.25
    assert shading_model.MIN_PERCEPTUAL_ROUGHNESS_FP16 == math.ceil(r_star * 1000) / 1000
    a2 = shading_model.alpha_from_perceptual(np.array([0.045, 0.088, 0.089]), dtype=HALF) ** 2
    assert a2[2] >= HALF_NORMAL_MIN > a2[1] and a2[0] < HALF_NORMAL_MIN / 10


def test_d_peak_in_half_safe_form_is_finite_exactly_above_the_overflow_roughness():
    """(alpha / t)^2 / pi at NdotH = 1 is (1/alpha)^2 / pi; the square overflows first, so D is
    finite iff 1/alpha^2 <= 65504, i.e. r >= 65504^(-1/4) = 0.0625, and accurate above it."""
    r_overflow = HALF_MAX ** -0.25
    for r in ROUGHNESS_GRID:
        d16 = shading_model.d_ggx_half_safe(1.0, r * r, dtype=HALF)
        if r < r_overflow * 0.99:
            assert np.isinf(d16), r
        elif r > r_overflow * 1.01:
            assert np.isfinite(d16) and _rel(d16, shading_model.d_ggx(1.0, r * r)) < 1e-2, r


def test_d_peak_in_the_textbook_form_underflows_in_half():
    """a2 / (pi t^2) squares t = a2 = r^4 at the peak: t^2 = r^8 is a normal half only for
    r >= 2^(-14/8) = 0.297; below, t^2 loses bits in the subnormals, and for r^8 < 2^-25 it
    flushes to 0 and the guard leaves a tiny, wrong D: the highlight collapses instead of
    overflowing. In float16 this form needs r >= 0.3; the half-safe form (above) 0.0625."""
    r_normal = 2.0 ** (-14 / 8)
    assert 0.296 < r_normal < 0.298
    errors = {r: _rel(shading_model.d_ggx(1.0, r * r, dtype=HALF), shading_model.d_ggx(1.0, r * r))
              for r in ROUGHNESS_GRID}
    assert all(e < 1e-2 for r, e in errors.items() if r >= r_normal)
    assert any(e > 1e-2 for r, e in errors.items() if 0.1 < r < r_normal)
    r_flush = 2.0 ** (-25 / 8)   # r^8 below half the smallest subnormal rounds to 0
    for r in (0.045, 0.06):
        assert r < r_flush
        d16 = float(shading_model.d_ggx(1.0, r * r, dtype=HALF))
        assert np.isfinite(d16) and d16 < 1e-2 * shading_model.d_ggx(1.0, r * r)
    # r = 0.01: alpha^2 = 1e-8 is below 2^-25 and rounds to 0, so D is 0 everywhere.
    assert float(shading_model.alpha_from_perceptual(0.01, dtype=HALF) ** 2) == 0.0
    assert float(shading_model.d_ggx(1.0, 1e-4, dtype=HALF)) == 0.0


def test_half_cannot_resolve_n_dot_h_for_smooth_lobes():
    """Halves just below 1 are spaced 2^-11, so 1 - NdotH moves in steps of 4.9e-4 while the
    lobe's own scale is a2: D evaluated from a half NdotH is off by tens of percent across the
    lobe for r = 0.25 (a2 = 3.9e-3) and within 2 % only from r = 0.5 (a2 = 0.0625)."""
    assert float(np.spacing(HALF(0.999))) == 2.0 ** -11

    def worst_over_lobe(r):
        a = r * r
        theta = np.linspace(0, 3 * a, 400)
        exact = shading_model.d_ggx(np.cos(theta), a)
        return float(np.max(np.abs(shading_model.d_ggx(np.cos(theta), a, dtype=HALF) / exact - 1)))

    assert worst_over_lobe(0.25) > 0.1
    assert worst_over_lobe(0.5) < 0.02


def test_visibility_at_the_n_dot_v_clamp_overflows_half_below_a_closed_form_roughness():
    """At NdotV = NdotL = x (the 1e-4 clamp) the height-correlated V is 0.25 / (x sqrt(x^2 (1 -
    a2) + a2)): wherever that passes 65504 (r < ~0.2) the half V is unusable -- Inf, or 0 once
    a2 and x^2 underflow too (r < ~0.012) -- and below it half V is within 2 %."""
    x = shading_model.MIN_N_DOT_V
    seen_inf = seen_finite = False
    for r in ROUGHNESS_GRID:
        a = r * r
        v64 = shading_model.vis_smith_ggx_correlated(x, x, a)
        assert v64 == pytest.approx(0.25 / (x * math.sqrt(x * x * (1 - a * a) + a * a)), rel=1e-12)
        v16 = shading_model.vis_smith_ggx_correlated(x, x, a, dtype=HALF)
        if v64 > HALF_MAX * 1.01:
            assert np.isinf(v16) or v16 == 0, r
            seen_inf = True
        elif v64 < HALF_MAX * 0.99:
            assert np.isfinite(v16) and _rel(v16, v64) < 2e-2, r
            seen_finite = True
    assert seen_inf and seen_finite


def test_half_brdf_at_the_fp16_clamp_is_finite_but_coarse():
    """With Filament's fp16 clamp the whole half BRDF stays finite over the visible hemisphere
    (away from the NdotV clamp), though only to several percent (NdotH resolution, above); at
    the fp32 clamp (0.045) its mirror-direction peak is lost."""
    rng = np.random.default_rng(5)
    n = np.tile([0.0, 0.0, 1.0], (4000, 1))
    v, l = shading_model.sample_sphere_cosine(rng, 4000), shading_model.sample_sphere_cosine(rng, 4000)
    keep = (v[:, 2] > 0.05) & (l[:, 2] > 0.05)
    args = (n[keep], v[keep], l[keep], np.array([0.9, 0.6, 0.3]), 1.0, 0.0)
    f16 = shading_model.brdf(*args, dtype=HALF, min_perceptual_roughness=shading_model.MIN_PERCEPTUAL_ROUGHNESS_FP16)
    f64 = shading_model.brdf(*args, min_perceptual_roughness=shading_model.MIN_PERCEPTUAL_ROUGHNESS_FP16)
    assert np.isfinite(f16).all()
    big = f64 > 1e-2
    assert np.median(np.abs(f16[big] / f64[big] - 1)) < 0.15
    # h = n exactly (v and l mirror images about n): the peak of the r = 0.045 lobe.
    peak = (np.array([0.0, 0, 1]), np.array([0.6, 0, 0.8]), np.array([-0.6, 0, 0.8]), np.ones(3), 1.0, 0.0)
    p16, p64 = shading_model.brdf(*peak, dtype=HALF), shading_model.brdf(*peak)
    assert np.isinf(p16).all() or float(p16.max()) < 1e-2 * float(p64.max())


def test_narkowicz_aces_overflows_in_half_but_its_curve_is_flat_there():
    """x (2.51 x + 0.03) passes 65504 at x ~ 161 in half, and inf / inf is NaN; in float64 the
    curve is exactly 1 (clamped) from x = 7.3 on, so capping the input loses nothing."""
    x = np.array([[100.0] * 3, [200.0] * 3, [1e4] * 3])
    with np.errstate(all="ignore"):
        half = display.tonemap(x, "aces", dtype=HALF)
    assert np.isfinite(half[0]).all() and np.isnan(half[2]).all()
    exact = display.tonemap(x, "aces")
    assert np.all(exact == 1.0)
    assert display.tonemap(np.array([7.3] * 3), "aces")[0] == 1.0


@pytest.mark.parametrize("name", display.TONEMAPPERS)
def test_the_tone_map_input_cap_changes_no_display_value(name):
    """tonemap.glsl caps its input at TONEMAP_INPUT_MAX so the ACES fits cannot overflow fp32;
    every curve is display white long before, so the 8-bit sRGB output is bit-identical for
    any input up to 1e30 and any ratio between channels."""
    from sdfpbr.spec.chart_spec import make_spec
    rng = np.random.default_rng(9)
    x = 10.0 ** rng.uniform(-3, 30, (20000, 3))
    dark = rng.random(20000) < 0.3                       # saturated colours: one channel at 0
    x[dark, rng.integers(0, 3, 20000)[dark]] = 0.0
    for white in (make_spec().reinhard_white, 1e-3, 1e6):
        capped = np.minimum(x, display.TONEMAP_INPUT_MAX)
        enc = [np.rint(display.srgb_oetf(display.tonemap(v, name, white=white)) * 255) for v in (x, capped)]
        np.testing.assert_array_equal(enc[0], enc[1])


def test_the_cap_is_in_the_display_program():
    import re
    text = render_plan(make_spec()).display.text
    assert float(re.search(r"#define TONEMAP_INPUT_MAX (\S+)", text).group(1)) == display.TONEMAP_INPUT_MAX
    assert "x = min(x, vec3(TONEMAP_INPUT_MAX));" in text


# ---- the renderer's half-float targets ---------------------------------------------------------

BLINDING = dict(env="black", ibl=False, ao=False, ground=False, shadows=False, rows=1, cols=3,
                roughness=(0.0, 0.3), metallic=(1, 1), base_color=(1, 1, 1), width=96, height=40,
                lights=(Light("directional", direction=(0.2, 0.3, 0.93), intensity=1e5),), quality="draft")


def test_the_half_clamp_is_composed_only_for_half_targets():
    assert "65504.0" in render_plan(make_spec(hdr_precision="float16")).chart.text
    assert "65504.0" not in render_plan(make_spec()).chart.text


def test_half_targets_stay_finite_and_saturate_at_half_max(session):
    full = session.render(make_spec(**BLINDING))
    half = session.render(make_spec(**BLINDING, hdr_precision="float16"))
    assert full.hdr.max() > 4 * HALF_MAX           # the highlight really is beyond half range
    assert np.isfinite(half.hdr).all() and half.hdr.min() >= 0
    assert half.hdr.max() == HALF_MAX
    over = full.hdr >= HALF_MAX
    np.testing.assert_array_equal(half.hdr[over], HALF_MAX)
    # Elsewhere the half target holds the float32 value rounded to half.
    expected = full.hdr[~over].astype(HALF).astype(np.float32)
    np.testing.assert_allclose(half.hdr[~over], expected, rtol=2.0 ** -10, atol=2.0 ** -24)


def test_half_target_display_is_the_tone_mapped_half_values(session):
    from sdfpbr.devtools.stress.checks import display_error
    spec = make_spec(**BLINDING, hdr_precision="float16", exposure=-18.0, tonemap="reinhard")
    res = session.render(spec)
    assert display_error(res.hdr, res.alpha, res.image, spec) [1] == 0


def test_half_targets_cost_at_most_one_lsb_below_half_max(session):
    """A half target rounds radiance to 11 bits; through tone map and sRGB that moves no
    display value by more than 1 LSB, wherever the float32 radiance is within half range."""
    spec = make_spec(**{**BLINDING, "lights": (Light("directional", direction=(0.2, 0.3, 0.93), intensity=3.0),)},
                     exposure=1.0, tonemap="aces")
    full = session.render(spec)
    half = session.render(make_spec(spec, hdr_precision="float16"))
    assert full.hdr.max() < HALF_MAX
    assert np.abs(full.image.astype(int) - half.image.astype(int)).max() <= 1
