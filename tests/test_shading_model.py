"""Tests of the float64 numpy model against docs/model.md (its formulas and test vectors).

Expected values are docs/model.md's test vectors, closed forms, or integrals computed here with an
integrator independent of the module (seeded Monte Carlo, or exact Gauss-Legendre on
polynomials) -- never the module's own output alone.
"""

import math
import time

import numpy as np
import pytest

from sdfpbr.oracle import display, shading_model

# docs/model.md, image-based light: (r, mu, E, A, B), height-correlated visibility, F = 1.
DFG_TABLE = [
    (0.25, 0.25, 0.96157, 0.75803, 0.20354),
    (0.25, 1.00, 0.99568, 0.99568, 0.00000),
    (0.50, 0.50, 0.85726, 0.83492, 0.02235),
    (0.50, 1.00, 0.91581, 0.91578, 0.00003),
    (0.75, 0.50, 0.66318, 0.65469, 0.00848),
    (1.00, 0.50, 0.45069, 0.44771, 0.00299),
    (1.00, 1.00, 0.306853, 0.30682, 0.00003),
]

# docs/model.md, tone mapping: gray in -> (Reinhard, ACES Narkowicz, ACES Hill, Khronos PBR Neutral).
TONE_TABLE = [
    (0.18, 0.152542, 0.266899, 0.105591, 0.140000),
    (1.0, 0.500000, 0.803797, 0.619115, 0.869091),
    (4.0, 0.800000, 0.973417, 0.909014, 0.983256),
]

Z = np.array([0.0, 0.0, 1.0])


def view_dir(mu):
    return np.array([math.sqrt(max(0.0, 1.0 - mu * mu)), 0.0, mu])


def srgb_formula(x):
    """IEC 61966-2-1 written out here, independent of the module."""
    return 12.92 * x if x <= 0.0031308 else 1.055 * x ** (1.0 / 2.4) - 0.055


# --- BRDF terms -------------------------------------------------------------

def test_alpha_and_k():
    assert shading_model.alpha_from_perceptual(0.5) == pytest.approx(0.25)
    assert shading_model.k_direct(0.5) == pytest.approx(1.5 ** 2 / 8)
    assert shading_model.k_ibl(0.5) == pytest.approx(0.125)
    assert shading_model.MIN_PERCEPTUAL_ROUGHNESS == 0.045


def test_d_ggx_peak_and_normalisation():
    for r in (0.045, 0.01):
        a = r * r
        assert shading_model.d_ggx(1.0, a) == pytest.approx(1.0 / (math.pi * a * a), rel=1e-12)
    # docs/model.md, conventions, peak values: r = 0.045 -> 7.8e4, r = 0.01 -> 3.2e7.
    assert shading_model.d_ggx(1.0, 0.045 ** 2) == pytest.approx(7.8e4, rel=0.01)
    assert shading_model.d_ggx(1.0, 0.01 ** 2) == pytest.approx(3.2e7, rel=0.01)
    # int D cos dw_h = 1 (projected microfacet area), own Gauss-Legendre in theta.
    x, w = np.polynomial.legendre.leggauss(2000)
    th = 0.25 * np.pi * (x + 1.0)
    wt = 0.25 * np.pi * w
    for a in (0.25, 0.6, 1.0):
        total = 2 * np.pi * np.sum(shading_model.d_ggx(np.cos(th), a) * np.cos(th) * np.sin(th) * wt)
        assert total == pytest.approx(1.0, abs=1e-6)
    # Same value as the textbook form away from the peak.
    nh, a = 0.9, 0.3
    a2 = a ** 4
    assert shading_model.d_ggx(nh, a * a) == pytest.approx(a2 / (math.pi * (nh * nh * (a2 - 1) + 1) ** 2), rel=1e-12)
    with np.errstate(divide="raise", over="raise", invalid="raise"):
        assert np.isfinite(shading_model.d_ggx(1.0, 0.0))


def test_visibility_terms():
    # alpha = 1: sqrt(...) = 1, so Vis = 0.5 / (NdotL + NdotV).
    assert shading_model.vis_smith_ggx_correlated(0.3, 0.7, 1.0) == pytest.approx(0.5)
    nl, nv, a = 0.4, 0.9, 0.3
    a2 = a * a
    expect = 0.5 / (nl * math.sqrt(nv * nv * (1 - a2) + a2) + nv * math.sqrt(nl * nl * (1 - a2) + a2))
    assert shading_model.vis_smith_ggx_correlated(nl, nv, a) == pytest.approx(expect, rel=1e-14)
    with np.errstate(divide="raise", over="raise", invalid="raise"):
        assert shading_model.vis_smith_ggx_correlated(0.0, 0.0, 0.0) == 0.0
        assert shading_model.vis_smith_ggx_correlated(np.zeros(3), np.zeros(3), 0.5).tolist() == [0, 0, 0]
    k = 0.2

    def g1(x):
        return x / (x * (1 - k) + k)

    assert shading_model.vis_schlick_ggx(nl, nv, k) == pytest.approx(g1(nl) * g1(nv) / (4 * nl * nv), rel=1e-14)


def test_fresnel_schlick():
    assert shading_model.fresnel_schlick(0.04, 1.0) == pytest.approx(0.04)
    assert shading_model.fresnel_schlick(0.04, 0.0) == pytest.approx(1.0)
    assert shading_model.fresnel_schlick(0.04, 0.5) == pytest.approx(0.04 + 0.96 * 0.5 ** 5)
    # x outside [0, 1] is clipped: no NaN from a negative base.
    assert shading_model.fresnel_schlick(0.04, 1.0 + 1e-7) == pytest.approx(0.04)
    rgb = shading_model.fresnel_schlick(np.array([1.0, 0.5, 0.0]), np.array([0.5, 1.0]))
    assert rgb.shape == (2, 3)
    assert rgb[1] == pytest.approx([1.0, 0.5, 0.0])
    assert rgb[0, 2] == pytest.approx(0.5 ** 5)


# --- split-sum integrals ----------------------------------------------------

@pytest.mark.parametrize("r, mu, e, a, b", DFG_TABLE)
def test_dfg_table_vectors(r, mu, e, a, b):
    A, B, _ = shading_model.dfg_integrate(mu, r)
    assert float(A) == pytest.approx(a, abs=1e-5)
    assert float(B) == pytest.approx(b, abs=1e-5)
    assert float(A + B) == pytest.approx(e, abs=1e-5)


def test_dfg_vectorised_and_exact_one_minus_ln2():
    r = np.array([x[0] for x in DFG_TABLE])
    mu = np.array([x[1] for x in DFG_TABLE])
    A, B, C = shading_model.dfg_integrate(mu, r)
    assert A.shape == B.shape == C.shape == (len(DFG_TABLE),)
    assert A + B == pytest.approx([x[2] for x in DFG_TABLE], abs=1e-5)
    A1, B1, _ = shading_model.dfg_integrate(1.0, 1.0)
    assert float(A1 + B1) == pytest.approx(1.0 - math.log(2.0), abs=1e-9)
    # Broadcasting: (3,) x (2, 1) -> (2, 3).
    A2, _, _ = shading_model.dfg_integrate(np.array([0.2, 0.5, 1.0]), np.array([[0.3], [0.8]]))
    assert A2.shape == (2, 3)


def test_dfg_limits_no_nan():
    with np.errstate(divide="raise", over="raise", invalid="raise"):
        for mu in (0.0, 1e-6, 0.3, 1.0):
            A, B, C = shading_model.dfg_integrate(mu, 0.0)
            fc = (1 - max(mu, 1e-4)) ** 5
            assert float(A) == pytest.approx(1 - fc, abs=1e-12)
            assert float(B) == pytest.approx(fc, abs=1e-12)
            for r in (0.045, 0.3, 1.0):
                vals = shading_model.dfg_integrate(mu, r)
                assert all(np.isfinite(v).all() for v in vals)
                assert 0.0 < float(vals[0] + vals[1]) <= 1.0 + 1e-9
    # Just above the delta cut the lobe is nearly a mirror: E close to 1 away from grazing.
    A, B, _ = shading_model.dfg_integrate(0.5, 0.0101)
    assert float(A + B) == pytest.approx(1.0, abs=1e-4)


def test_dfg_c_term_at_normal_incidence():
    # V = N: VdotH = cos(theta_l / 2) = t; cos-weighted measure 2 sin cos dtheta = 8 t (2t^2-1) dt
    # on t in [1/sqrt2, 1]. The integrand is a polynomial: Gauss-Legendre with 10 nodes is exact.
    x, w = np.polynomial.legendre.leggauss(10)
    lo, hi = 1 / math.sqrt(2), 1.0
    t = lo + (hi - lo) * 0.5 * (x + 1)
    integral = np.sum(8 * t * (2 * t * t - 1) * (1 - t) ** 5 * w) * 0.5 * (hi - lo)
    expect = 1.0 - 0.04 - 0.96 * integral
    for r in (0.1, 0.5, 1.0):
        assert float(shading_model.dfg_integrate(1.0, r)[2]) == pytest.approx(expect, abs=1e-10)


def test_dfg_c_term_monte_carlo():
    # Independent cosine-weighted MC of 1 - Fd(VdotH) at a grazing-ish view.
    rng = np.random.default_rng(7)
    n = 200_000
    u1, u2 = rng.random(n), rng.random(n)
    s = np.sqrt(u1)
    l = np.stack([s * np.cos(2 * np.pi * u2), s * np.sin(2 * np.pi * u2), np.sqrt(1 - u1)], -1)
    v = view_dir(0.2)
    h = (l + v) / np.linalg.norm(l + v, axis=-1, keepdims=True)
    g = 1.0 - (0.04 + 0.96 * (1 - np.abs(h @ v)) ** 5)
    se = g.std() / math.sqrt(n)
    assert float(shading_model.dfg_integrate(0.2, 0.7)[2]) == pytest.approx(g.mean(), abs=3 * se + 1e-12)


def test_schlick_ggx_model_differs_and_is_finite():
    Ag, Bg, _ = shading_model.dfg_integrate(0.5, 0.5, model="gltf")
    As, Bs, _ = shading_model.dfg_integrate(0.5, 0.5, model="schlick-ggx")
    assert np.isfinite([As, Bs]).all()
    assert abs(float(As + Bs) - float(Ag + Bg)) > 1e-3
    with pytest.raises(ValueError):
        shading_model.dfg_integrate(0.5, 0.5, model="beckmann")


def test_e_avg_reference():
    assert float(shading_model.e_avg(0.5)) == pytest.approx(0.882323, abs=1e-6)
    assert float(shading_model.e_avg(1.0)) == pytest.approx(0.409137, abs=1e-6)


def test_dfg_table_layout_and_speed():
    t0 = time.perf_counter()
    lut = shading_model.dfg_table(32)
    assert time.perf_counter() - t0 < 10.0
    assert lut.shape == (32, 32, 3) and lut.dtype == np.float64
    assert np.isfinite(lut).all()
    # Row j = roughness, column i = n_dot_v. C does not depend on roughness.
    assert np.ptp(lut[:, :, 2], axis=0).max() < 1e-12
    e = lut[..., 0] + lut[..., 1]
    assert (np.diff(e[:, -1]) < 0).all()  # at mu ~ 1, E falls with roughness
    # Texel centres: size 4, [j=1, i=1] is r = mu = 0.375; [j=3, i=0] is r = 0.875, mu = 0.125.
    small = shading_model.dfg_table(4)
    a, b, _ = shading_model.dfg_integrate(0.375, 0.375)
    assert small[1, 1, :2] == pytest.approx([float(a), float(b)], abs=1e-12)
    a, b, _ = shading_model.dfg_integrate(0.125, 0.875)
    assert small[3, 0, :2] == pytest.approx([float(a), float(b)], abs=1e-12)


# --- white furnace (docs/model.md) --------------------------------------------

def test_white_metal_furnace_compensated_is_one():
    mu = np.array([1e-4, 0.05, 0.25, 0.5, 0.8, 1.0])
    r = np.array([[0.0], [0.045], [0.25], [0.5], [0.75], [1.0]])
    out = shading_model.furnace_expected(mu, 1.0, 1.0, r, multiscatter=True)
    assert out.shape == (6, 6, 3)
    assert np.abs(out - 1.0).max() < 1e-9


@pytest.mark.parametrize("r, mu, e, a, b", DFG_TABLE)
def test_white_metal_furnace_uncompensated_is_e(r, mu, e, a, b):
    out = shading_model.furnace_expected(mu, 1.0, 1.0, r, multiscatter=False)
    assert out == pytest.approx([e, e, e], abs=1e-5)


def test_furnace_lobes_compensated_separately():
    # metallic 0.5 with a coloured base: per-lobe comp, then mix (not one blended f0).
    mu, r = 0.5, 0.5
    e = 0.85726
    a, b = 0.83492, 0.02235
    base = np.array([0.9, 0.5, 0.1])
    c = float(shading_model.dfg_integrate(mu, r)[2])
    def comp(f0):
        return 1 + f0 * (1 / e - 1)
    diel = base * c + (0.04 * a + b) * comp(0.04)
    metal = (base * a + b) * comp(base)
    expect = 0.5 * diel + 0.5 * metal
    got = shading_model.furnace_expected(mu, base, 0.5, r)
    assert got == pytest.approx(expect, abs=3e-5)
    f0_blend = 0.5 * 0.04 + 0.5 * base
    blended = 0.5 * base * c + (f0_blend * a + b) * comp(f0_blend)
    assert np.abs(got - blended).max() > 1e-3


def test_dielectric_literal_coupling_gains_energy_at_grazing():
    # docs/model.md, the white furnace: the literal Appendix-B coupling reflects more than 1. Assert it.
    for ms in (False, True):
        out = shading_model.furnace_expected(0.05, 1.0, 0.0, 0.045, multiscatter=ms)
        assert (out > 1.0).all()
        assert (out > 1.5).all()  # not a rounding artefact: a large gain


def _mc_hemisphere(mu, base, metallic, r, multiscatter, n=200_000, seed=1):
    """Uniform-hemisphere MC of int f cos dl; returns (mean, standard error) per channel."""
    rng = np.random.default_rng(seed)
    u1, u2 = rng.random(n), rng.random(n)
    ct = u1
    st = np.sqrt(1 - ct * ct)
    phi = 2 * np.pi * u2
    l = np.stack([st * np.cos(phi), st * np.sin(phi), ct], -1)
    v = np.broadcast_to(view_dir(mu), l.shape)
    f = shading_model.brdf(Z, v, l, base, metallic, r, multiscatter=multiscatter)
    g = f * ct[:, None] * 2 * np.pi  # pdf = 1 / (2 pi)
    return g.mean(axis=0), g.std(axis=0) / math.sqrt(n)


@pytest.mark.parametrize("r, mu, e", [(0.5, 0.5, 0.85726), (1.0, 0.5, 0.45069), (0.75, 0.5, 0.66318)])
def test_monte_carlo_white_metal(r, mu, e):
    mean, se = _mc_hemisphere(mu, 1.0, 1.0, r, multiscatter=False)
    assert np.all(np.abs(mean - e) < 3 * se + 1e-5)
    expect = shading_model.furnace_expected(mu, 1.0, 1.0, r, multiscatter=False)
    assert np.all(np.abs(mean - expect) < 3 * se)
    mean, se = _mc_hemisphere(mu, 1.0, 1.0, r, multiscatter=True)
    assert np.all(np.abs(mean - 1.0) < 3 * se)


def test_monte_carlo_mixed_material_matches_split_sum():
    base = np.array([0.9, 0.5, 0.1])
    mean, se = _mc_hemisphere(0.6, base, 0.5, 0.7, multiscatter=True, seed=3)
    expect = shading_model.furnace_expected(0.6, base, 0.5, 0.7, multiscatter=True)
    assert np.all(np.abs(mean - expect) < 3 * se)


def test_brdf_point_value():
    # V = L = N: h = n, VdotH = 1, Fc = 0. Dielectric: base/pi * 0.96 + D Vis * 0.04.
    r, base = 0.5, np.array([0.8, 0.4, 0.2])
    a = r * r
    d = 1 / (math.pi * a * a)
    vis = 0.5 / (1.0 + 1.0)  # NdotL = NdotV = 1: both square roots are 1
    f = shading_model.brdf(Z, Z, Z, base, 0.0, r)
    assert f == pytest.approx(base / math.pi * 0.96 + d * vis * 0.04, rel=1e-12)
    f = shading_model.brdf(Z, Z, Z, base, 1.0, r)
    assert f == pytest.approx(d * vis * base, rel=1e-12)
    # schlick-ggx at NdotL = NdotV = 1: Vis = 1/4 whatever k is.
    f = shading_model.brdf(Z, Z, Z, 1.0, 1.0, r, model="schlick-ggx")
    assert f == pytest.approx([d / 4] * 3, rel=1e-12)
    # Roughness 0 is clamped to 0.045 before alpha.
    assert shading_model.brdf(Z, Z, Z, 1.0, 1.0, 0.0) == pytest.approx(shading_model.brdf(Z, Z, Z, 1.0, 1.0, 0.045))
    # e_spec overrides the integrated E: metal comp = 1 + base (1/E - 1).
    plain = shading_model.brdf(Z, Z, Z, base, 1.0, r)
    comp = shading_model.brdf(Z, Z, Z, base, 1.0, r, multiscatter=True, e_spec=0.5)
    assert comp == pytest.approx(plain * (1 + base), rel=1e-12)


def test_brdf_below_horizon_is_zero():
    l = np.array([0.6, 0.0, -0.8])
    assert shading_model.brdf(Z, view_dir(0.5), l, 1.0, 0.0, 0.5).tolist() == [0.0, 0.0, 0.0]
    assert shading_model.brdf(Z, view_dir(0.5), np.array([1.0, 0.0, 0.0]), 1.0, 1.0, 0.5).tolist() == [0, 0, 0]


def test_brdf_no_nan_at_edges():
    with np.errstate(divide="raise", over="raise", invalid="raise"):
        for r in (0.0, 0.045, 1.0):
            for mu in (0.0, 1e-6, 0.5, 1.0):
                v = view_dir(mu)
                ls = np.array([Z, np.array([-v[0], 0.0, v[2]]), np.array([1.0, 0.0, 0.0]),
                               v, -v, np.array([0.0, 1.0, 0.0]), shading_model.normalize([-1, 0, 1e-6])])
                for metallic in (0.0, 1.0):
                    for ms in (False, True):
                        f = shading_model.brdf(Z, np.broadcast_to(v, ls.shape), ls, [1.0, 0.5, 0.0],
                                        metallic, r, multiscatter=ms)
                        assert f.shape == (len(ls), 3)
                        assert np.isfinite(f).all(), (r, mu, metallic, ms)
                        assert (f >= 0).all()


# --- tone mapping and encoding (docs/model.md) ---------------------------------

@pytest.mark.parametrize("x, rein, nark, hill, neutral", TONE_TABLE)
def test_tonemap_reference_values(x, rein, nark, hill, neutral):
    g = np.full(3, x)
    assert display.tonemap(g, "reinhard") == pytest.approx([rein] * 3, abs=1e-6)
    assert display.tonemap(g, "aces") == pytest.approx([nark] * 3, abs=1e-6)
    assert display.tonemap(g, "neutral") == pytest.approx([neutral] * 3, abs=1e-6)
    # Hill: R and G rows of the published matrices sum exactly to 1; the last output row
    # sums to 0.99999, so B sits up to ~6e-6 lower (checked in the gray test below).
    assert display.tonemap(g, "aces-hill")[:2] == pytest.approx([hill] * 2, abs=1e-6)


def test_aces_hill_gray_stays_gray():
    for x in (0.0, 0.01, 0.18, 1.0, 4.0, 16.0):
        out = display.tonemap(np.full(3, x), "aces-hill")
        assert np.ptp(out) < 1e-5, (x, out)  # a transposed (column-major) matrix gives ~0.1
    # And it is not a per-channel curve: a saturated red bleeds into G and B.
    red = display.tonemap(np.array([1.0, 0.0, 0.0]), "aces-hill")
    assert red[1] > 0.0 or red[2] > 0.0
    # Stacked pixels (..., 3) work.
    assert display.tonemap(np.full((4, 5, 3), 0.18), "aces-hill").shape == (4, 5, 3)


def test_other_tonemappers():
    x = np.array([-0.5, 0.5, 5.0])
    assert display.tonemap(x, "none").tolist() == [-0.5, 0.5, 5.0]
    assert display.tonemap(x, "clamp").tolist() == [0.0, 0.5, 1.0]
    # Extended Reinhard maps the white point (4.0 by default) to exactly 1.
    assert display.tonemap(np.full(3, 4.0), "reinhard-extended") == pytest.approx([1.0] * 3)
    assert display.tonemap(np.full(3, 2.0), "reinhard-extended", white=2.0) == pytest.approx([1.0] * 3)
    assert display.tonemap(np.full(3, 1.0), "reinhard-extended") == pytest.approx([1 * (1 + 1 / 16) / 2] * 3)
    assert tuple(display.TONEMAP_CURVES) == display.TONEMAPPERS   # a float64 function per row of the table
    for name in display.TONEMAPPERS:
        assert display.tonemap(np.full((2, 3), 0.5), name).shape == (2, 3)
    with pytest.raises(ValueError):
        display.tonemap(x, "filmic")


def test_neutral_below_knee_is_offset_only():
    # Below the knee only the toe offset applies: x - (m - 6.25 m^2) for min channel m < 0.08.
    c = np.array([0.05, 0.3, 0.5])
    m = 0.05
    assert display.tonemap(c, "neutral") == pytest.approx(c - (m - 6.25 * m * m), abs=1e-12)


def test_srgb_and_gamma():
    assert display.srgb_oetf([0.18, 0.01, 0.001]) == pytest.approx([0.461356, 0.099853, 0.012920], abs=1e-6)
    assert display.gamma_oetf([0.18, 0.01, 0.001]) == pytest.approx([0.458656, 0.123285, 0.043288], abs=1e-6)
    assert display.srgb_oetf([-1.0, 2.0]) == pytest.approx([0.0, 1.0], abs=1e-15)
    x = np.linspace(0, 1, 1001)
    assert display.srgb_eotf(display.srgb_oetf(x)) == pytest.approx(x, abs=1e-12)
    assert display.srgb_eotf(0.461356) == pytest.approx(0.18, abs=1e-6)


def test_encode_srgb8():
    out = display.encode_srgb8(np.array([0.18, 0.0, 4.0]), tonemap="none")
    assert out.dtype == np.uint8
    assert out.tolist() == [round(0.461356 * 255), 0, 255]
    # Exposure comes before the tone map: 0.09 at +1 EV reads as 0.18.
    assert display.encode_srgb8(np.full(3, 0.09), exposure_ev=1.0, tonemap="none").tolist() == [118] * 3
    # Default ACES (Narkowicz): 1.0 -> 0.803797 -> sRGB.
    expect = round(srgb_formula(0.803797) * 255)
    assert display.encode_srgb8(np.ones((2, 2, 3))).tolist() == [[[expect] * 3] * 2] * 2
    # Reinhard at 1.0 -> 0.5 -> 0.735357 -> 188.
    assert display.encode_srgb8(np.ones(3), tonemap="reinhard").tolist() == [round(srgb_formula(0.5) * 255)] * 3


# --- helpers ------------------------------------------------------------------

def test_helpers():
    assert shading_model.normalize([3.0, 0.0, 4.0]) == pytest.approx([0.6, 0.0, 0.8])
    assert shading_model.normalize(np.zeros(3)).tolist() == [0.0, 0.0, 0.0]
    v = shading_model.normalize([1.0, 0.0, 1.0])
    # GLSL convention: reflect(I, N) = I - 2 dot(N, I) N; the mirror direction of V is reflect(-V, N).
    assert shading_model.reflect(-v, Z) == pytest.approx([-v[0], 0.0, v[2]])
    d = shading_model.sample_sphere_cosine(np.random.default_rng(0), 100_000)
    assert d.shape == (100_000, 3)
    assert np.linalg.norm(d, axis=-1) == pytest.approx(np.ones(100_000))
    assert (d[:, 2] >= 0).all()
    # Cosine-weighted: E[cos] = 2/3, E[cos^2] = 1/2.
    assert d[:, 2].mean() == pytest.approx(2 / 3, abs=5e-3)
    assert (d[:, 2] ** 2).mean() == pytest.approx(0.5, abs=5e-3)
