"""LDR- and HDR-FLIP in numpy (sdfpbr.image.flip) against the paper's equations worked in float64 with
textbook constants, and against flip-evaluator (the reference implementation) on renders,
noise, edges and odd sizes."""
import numpy as np
import pytest

from sdfpbr.image.flip import hdr_exposures, hdr_flip, ldr_flip

PPD = 67.0

# How far apart two FLIP programs may be: float32 rounding differs (their filters sum in
# another order; sums of 21 taps of values up to 100 round at ~1e-5), and pow(., 0.7) and
# pow(., 0.5) amplify it near 0. A map is shown as an 8-bit heat map and its mean printed with
# three decimals: agreeing within half a heat-map level per pixel and a tenth of the printed
# digit on the mean, the two programs give the same picture and the same figure.
MAP_TOLERANCE = 0.5 / 255
MEAN_TOLERANCE = 1e-4


# --- the paper's equations in float64, textbook constants ----------------------------------------

SRGB_TO_XYZ = np.array([[0.4124564, 0.3575761, 0.1804375],       # IEC 61966-2-1, D65
                        [0.2126729, 0.7151522, 0.0721750],
                        [0.0193339, 0.1191920, 0.9503041]])
D65 = np.array([0.95047, 1.0, 1.08883])


def _lab_hunt(rgb8):
    c = np.asarray(rgb8, float) / 255.0
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    t = SRGB_TO_XYZ @ linear / D65
    d = 6 / 29
    f = np.where(t > d ** 3, np.cbrt(t), t / (3 * d * d) + 4 / 29)
    L, a, b = 116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])
    return np.array([L, 0.01 * L * a, 0.01 * L * b])                 # Hunt: chroma scaled by L / 100


def _hyab(p, q):
    return abs(p[0] - q[0]) + np.hypot(p[1] - q[1], p[2] - q[2])


def _flat_flip(rgb_ref, rgb_test):
    """FLIP of two flat images: no features, the filters keep a constant, so the error is the
    remapped colour difference (paper eq. 3-4: q_c = 0.7, p_c = 0.4, p_t = 0.95), with the
    largest difference that of green and blue."""
    c_max = _hyab(_lab_hunt((0, 255, 0)), _lab_hunt((0, 0, 255))) ** 0.7
    c = _hyab(_lab_hunt(rgb_ref), _lab_hunt(rgb_test)) ** 0.7
    knee = 0.4 * c_max
    return c * 0.95 / knee if c < knee else 0.95 + (c - knee) / (c_max - knee) * 0.05


def test_published_lab_of_green_and_blue_give_the_largest_difference():
    """The textbook sRGB primaries in CIELab (green 87.735, -86.183, 83.179; blue 32.303,
    79.197, -107.864) agree with the float64 equations above, which the flat tests use."""
    for rgb, lab in (((0, 255, 0), (87.735, -86.183, 83.179)), ((0, 0, 255), (32.303, 79.197, -107.864))):
        L, a, b = lab
        np.testing.assert_allclose(_lab_hunt(rgb), [L, 0.01 * L * a, 0.01 * L * b], atol=0.01)


@pytest.mark.parametrize("ref, test", [((0, 0, 0), (255, 255, 255)), ((128, 128, 128), (120, 128, 128)),
                                       ((200, 40, 30), (190, 60, 30)), ((0, 255, 0), (0, 0, 255)),
                                       ((90, 90, 200), (90, 90, 200))])
def test_flat_images_match_the_closed_form(ref, test):
    h, w = 24, 37
    a = np.full((h, w, 3), ref, np.uint8)
    b = np.full((h, w, 3), test, np.uint8)
    error = ldr_flip(a, b, PPD)
    assert error.shape == (h, w) and error.dtype == np.float32
    # The textbook constants differ from FLIP's in the fifth digit (D65's X 0.95047 against
    # 0.9504285); a difference of two nearby colours magnifies that up to tenfold.
    np.testing.assert_allclose(error, _flat_flip(ref, test), rtol=1e-3, atol=1e-6)


def test_identical_images_are_zero_and_order_does_not_matter_for_flat_colours():
    rng = np.random.default_rng(5)
    a = rng.integers(0, 256, (33, 20, 3), np.uint8)
    assert not ldr_flip(a, a, PPD).any()
    flat_a, flat_b = np.full((8, 8, 3), 40, np.uint8), np.full((8, 8, 3), 90, np.uint8)
    np.testing.assert_allclose(ldr_flip(flat_a, flat_b, PPD), ldr_flip(flat_b, flat_a, PPD), rtol=1e-6)


def _shifted_step():
    """A step of luminance and the same step moved right by one pixel (column 16 changes)."""
    a = np.full((32, 32, 3), 60, np.uint8)
    a[:, 16:] = 200
    b = np.full((32, 32, 3), 60, np.uint8)
    b[:, 17:] = 200
    return a, b


def test_a_moved_edge_errs_only_within_the_filters_reach():
    """Only column 16 differs. The colour filters reach ceil(3 sqrt(b_max / (2 pi^2)) ppd) pixels,
    b_max = 0.04 the paper's widest CSF scale (the blue-yellow channel), the feature filters
    ceil(3 x 0.5 x 0.082 ppd) = 9: beyond the wider the filtered images are equal and so is the
    error, exactly 0. The image is the same down every column, so
    is its map. (Its values: test_agrees_with_flip_evaluator, case "moved edge".)"""
    a, b = _shifted_step()
    error = ldr_flip(a, b, PPD)
    reach = int(np.ceil(3 * np.sqrt(0.04 / (2 * np.pi ** 2)) * PPD))
    assert reach == 10
    assert not error[:, :16 - reach].any() and not error[:, 16 + reach + 1:].any()
    assert (error == error[:1]).all()
    assert error[:, 16].min() > 0 and error.max() <= 1


def test_float_input_is_the_uint8_input_scaled():
    rng = np.random.default_rng(9)
    a, b = (rng.integers(0, 256, (20, 24, 3), np.uint8) for _ in range(2))
    np.testing.assert_allclose(ldr_flip(a / np.float32(255), b / np.float32(255), PPD), ldr_flip(a, b, PPD),
                               atol=1e-5)


# --- flip-evaluator, the reference implementation ------------------------------------------------

def _evaluator(ref, test, ppd=PPD):
    import flip_evaluator
    error_map, mean, _ = flip_evaluator.evaluate(ref.astype(np.float32) / 255, test.astype(np.float32) / 255, "LDR",
                                                 inputsRGB=True, applyMagma=False, computeMeanError=True,
                                                 parameters={"ppd": ppd})
    return float(mean), np.asarray(error_map, np.float32).reshape(ref.shape[:2])


def _render_pair(bug: str, **options):
    from sdfpbr.api import chart
    from sdfpbr.spec.chart_spec import make_spec
    spec = make_spec(width=160, height=120, labels=False, quality="draft", **options)
    return tuple(chart(s).image[..., :3] for s in (spec, make_spec(spec, bugs=(bug,))))


def _pairs():
    rng = np.random.default_rng(17)
    noise = rng.integers(0, 256, (40, 56, 3), np.uint8)
    yield "noise", noise, np.clip(noise.astype(int) + rng.integers(-60, 60, noise.shape), 0, 255).astype(np.uint8)
    smooth = np.linspace(0, 255, 64 * 48 * 3).reshape(64, 48, 3).astype(np.uint8)
    yield "gradient vs shifted", smooth, np.roll(smooth, 3, axis=1)
    tiny = rng.integers(0, 256, (3, 5, 3), np.uint8)                  # smaller than the filters' radius
    yield "3x5", tiny, tiny[::-1].copy()
    yield "one row", noise[:1], noise[1:2]
    disc = np.zeros((61, 47, 3), np.uint8)
    yy, xx = np.mgrid[:61, :47]
    disc[(yy - 30) ** 2 + (xx - 23) ** 2 < 200] = (250, 180, 40)
    yield "disc vs half-tone disc", disc, (disc // 2)
    yield "moved edge", *_shifted_step()


@pytest.mark.requires_extra("flip_evaluator")
@pytest.mark.parametrize("case", list(_pairs()), ids=lambda case: case[0])
def test_agrees_with_flip_evaluator(case):
    _, ref, test = case
    want_mean, want = _evaluator(ref, test)
    got = ldr_flip(ref, test, PPD)
    assert np.abs(got - want).max() <= MAP_TOLERANCE
    assert abs(float(got.mean(dtype=np.float64)) - want_mean) <= MEAN_TOLERANCE


@pytest.mark.requires_extra("flip_evaluator")
@pytest.mark.parametrize("bug, options", [("unsquared-roughness", {}), ("gamma-2.2", {}),
                                          ("normal-map-green-flip", {"textures": "hammered"})])
def test_agrees_with_flip_evaluator_on_bug_renders(bug, options, cache_dir):
    """The pairs the gallery and `compare` measure: a chart and the same chart with a bug."""
    ref, test = _render_pair(bug, **options)
    want_mean, want = _evaluator(ref, test)
    got = ldr_flip(ref, test, PPD)
    assert want_mean > 0.005                                          # a pair that differs
    assert np.abs(got - want).max() <= MAP_TOLERANCE
    assert abs(float(got.mean(dtype=np.float64)) - want_mean) <= MEAN_TOLERANCE


@pytest.mark.requires_extra("flip_evaluator")
def test_agrees_with_flip_evaluator_at_another_viewing_distance():
    rng = np.random.default_rng(3)
    a = rng.integers(0, 256, (30, 30, 3), np.uint8)
    b = np.clip(a.astype(int) + 25, 0, 255).astype(np.uint8)
    for ppd in (20.0, 110.0):
        want_mean, want = _evaluator(a, b, ppd)
        got = ldr_flip(a, b, ppd)
        assert np.abs(got - want).max() <= MAP_TOLERANCE
        assert abs(float(got.mean(dtype=np.float64)) - want_mean) <= MEAN_TOLERANCE


# --- HDR-FLIP ------------------------------------------------------------------------------------

def test_hdr_exposures_put_the_brightest_and_the_median_pixel_at_0_85():
    """Start: the exposure at which ACES maps the reference's brightest luminance to 0.85; stop:
    its median's (HDR-FLIP, Andersson et al. 2021). ACES here is FLIP's fit with the 0.6
    pre-exposure cancelled, solved for 0.85 by bisection in float64."""
    def aces(x):
        x = 0.6 * x
        return x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14)
    lo, hi = 0.0, 100.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if aces(mid) < 0.85 else (lo, mid)
    x_085 = 0.5 * (lo + hi)
    lum = np.array([[0.5, 2.0, 0.25], [8.0, 1.0, 0.125]], np.float32)     # grey pixels: luminance = value
    image = np.repeat(lum[..., None], 3, axis=2)
    start, stop = hdr_exposures(image)
    assert start == pytest.approx(np.log2(x_085 / 8.0), abs=1e-4)
    assert stop == pytest.approx(np.log2(x_085 / 1.0), abs=1e-4)       # the upper median of six
    assert hdr_exposures(np.zeros((4, 4, 3), np.float32)) == (0.0, 0.0)
    mostly_black = np.zeros((4, 4, 3), np.float32)
    mostly_black[0, 0] = 2.0
    assert np.isfinite(hdr_exposures(mostly_black)).all()             # median 0: the least non-zero stands in


def test_hdr_flip_of_a_scaled_copy_is_the_ldr_flip_at_each_exposure():
    """Identical images: 0. One exposure range given: the map is the per-pixel largest of the
    LDR-FLIPs of the tone-mapped pair at each exposure, at least two."""
    rng = np.random.default_rng(2)
    a = (rng.random((24, 30, 3)) ** 2 * 3).astype(np.float32)
    assert not hdr_flip(a, a, PPD)[0].any()
    b = a * np.float32(1.2)
    error, used = hdr_flip(a, b, PPD, exposures=(-1.0, 1.0))
    assert used["numExposures"] == 2
    def aces(x):
        x = 0.6 * x.astype(np.float64)
        return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0, 1)
    def srgb8(linear):
        c = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1 / 2.4) - 0.055)
        return c.astype(np.float32)
    each = [ldr_flip(srgb8(aces(a * 2.0 ** e)), srgb8(aces(b * 2.0 ** e)), PPD) for e in (-1.0, 1.0)]
    np.testing.assert_allclose(error, np.maximum(*each), atol=MAP_TOLERANCE)


def _hdr_pairs():
    rng = np.random.default_rng(21)
    sky = (rng.random((40, 52, 3)) ** 3 * 4).astype(np.float32)
    sky[10:18, 20:30] = 60.0                                              # a sun: many stops above the median
    yield "noise with a sun", sky, (sky * np.float32(1.15)).astype(np.float32)
    ramp = np.linspace(0, 20, 33 * 29 * 3, dtype=np.float32).reshape(33, 29, 3)
    yield "ramp vs blurred ramp", ramp, np.roll(ramp, 2, axis=0)


@pytest.mark.requires_extra("flip_evaluator")
@pytest.mark.parametrize("case", list(_hdr_pairs()), ids=lambda case: case[0])
def test_hdr_agrees_with_flip_evaluator(case):
    import flip_evaluator
    _, ref, test = case
    want_map, want_mean, used = flip_evaluator.evaluate(ref, test, "HDR", applyMagma=False, computeMeanError=True,
                                                        parameters={"ppd": PPD})
    want_map = np.asarray(want_map, np.float32).reshape(ref.shape[:2])
    got, ours = hdr_flip(ref, test, PPD)
    assert ours["numExposures"] == used["numExposures"]
    assert ours["startExposure"] == pytest.approx(used["startExposure"], abs=1e-5)
    assert ours["stopExposure"] == pytest.approx(used["stopExposure"], abs=1e-5)
    assert np.abs(got - want_map).max() <= MAP_TOLERANCE
    assert abs(float(got.mean(dtype=np.float64)) - want_mean) <= MEAN_TOLERANCE


@pytest.mark.requires_extra("flip_evaluator")
def test_hdr_agrees_with_flip_evaluator_on_a_render_and_its_draft(cache_dir):
    """What the bench measures: a chart's linear radiance against a noisier render of it."""
    from sdfpbr.api import chart
    from sdfpbr.spec.chart_spec import make_spec
    import flip_evaluator
    spec = make_spec(width=128, height=96, labels=False)
    ref = np.maximum(chart(spec, hdr=True).hdr[..., :3], 0).astype(np.float32)
    test = np.maximum(chart(make_spec(spec, quality="draft"), hdr=True).hdr[..., :3], 0).astype(np.float32)
    want_map, want_mean, _ = flip_evaluator.evaluate(ref, test, "HDR", applyMagma=False, computeMeanError=True,
                                                     parameters={"ppd": PPD})
    got, _ = hdr_flip(ref, test, PPD)
    assert want_mean > 0.001
    assert np.abs(got - np.asarray(want_map, np.float32).reshape(ref.shape[:2])).max() <= MAP_TOLERANCE
    assert abs(float(got.mean(dtype=np.float64)) - want_mean) <= MEAN_TOLERANCE


def test_a_kept_reference_gives_the_map_a_fresh_one_gives():
    """ldr_flip keeps a reference's half of the work by its content (a catalog measures a dozen
    bugs against one correct chart): each map equals the one measured with nothing kept, also
    after the reference array is changed in place and at another viewing distance."""
    from sdfpbr.image import flip
    rng = np.random.default_rng(7)
    ref = rng.integers(0, 256, (40, 56, 3), dtype=np.uint8)
    tests = [rng.integers(0, 256, ref.shape, dtype=np.uint8) for _ in range(2)]

    def fresh(r, t, ppd):
        return flip._flip_linear(flip._linear(r), flip._linear(t), ppd)
    for t in tests:
        np.testing.assert_array_equal(ldr_flip(ref, t, 67.0), fresh(ref, t, 67.0))
    np.testing.assert_array_equal(ldr_flip(ref, tests[0], 30.0), fresh(ref, tests[0], 30.0))
    before = ldr_flip(ref, tests[1], 67.0)
    ref[5, 7] = 255 - ref[5, 7]                   # the same array, one pixel changed
    after = ldr_flip(ref, tests[1], 67.0)
    np.testing.assert_array_equal(after, fresh(ref, tests[1], 67.0))
    assert not np.array_equal(after, before)
