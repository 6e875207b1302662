"""The tone-mapper table and AgX: every row has its GLSL branch and float64 function, the shader
schema and the spec read the table, AgX's float64 function against values derived by hand, and
its GLSL against that function through the display program and a chart render."""
from fractions import Fraction

import numpy as np
import pytest

from sdfpbr.devtools.stress.checks import display_error
from sdfpbr.gpu.programs import set_uniforms
from sdfpbr.image import colour
from sdfpbr.oracle import display
from sdfpbr.shading.plan import SCHEMA, compose_program, display_options
from sdfpbr.spec.chart_spec import make_spec
from sdfpbr.spec.fields import resolve_field
from sdfpbr.spec.presets import ENV_PRESETS, INTERSECTIONS, STAGES, TONE_MAPPERS, TONEMAPPERS

# AgX's sigmoid, the published decimals as exact fractions (highest power first).
SIGMOID = [Fraction(c) for c in ("15.5", "-40.14", "31.96", "-6.868", "0.4298", "0.1191", "-0.00232")]


def sigmoid(x: Fraction) -> float:
    return float(sum(c * x ** (6 - i) for i, c in enumerate(SIGMOID)))


def grey(value):
    return np.full(3, float(value))


def test_the_table_is_what_the_spec_and_the_shader_schema_take():
    names = [t.name for t in TONE_MAPPERS]
    assert len(set(names)) == len(names) and len({t.glsl for t in TONE_MAPPERS}) == len(names)
    assert tuple(names) == TONEMAPPERS == resolve_field("tonemap").choices == resolve_field("tonemap").sweep
    assert SCHEMA.choices["TONEMAP"] == tuple(t.glsl for t in TONE_MAPPERS)
    assert SCHEMA.choices["ENV"] == (*ENV_PRESETS, "file")
    assert SCHEMA.choices["STAGE"] == STAGES and SCHEMA.choices["INTERSECT"] == INTERSECTIONS
    for t in TONE_MAPPERS:   # its float64 function, and its branch in the composed display program
        assert display.TONEMAP_CURVES[t.name] is getattr(display, f"tonemap_{t.glsl}")
        if t.name not in ("none", "clamp", "reinhard", "reinhard-extended"):   # one-liners written inline
            text = compose_program("display_main.glsl", display_options(make_spec(tonemap=t.name))).text
            assert f"return tonemap_{t.glsl}(x);" in text
        assert f"{t.name} ({t.label})" in resolve_field("tonemap").help


# ---- colour: the primaries' matrices against the published ones ----------------------------

def test_rgb_matrices_from_the_primaries_match_the_published_ones():
    # IEC 61966-2-1 (sRGB) RGB -> XYZ, and ITU-R BT.2087's Rec. 709 -> Rec. 2020, to their 4 places.
    srgb_xyz = [[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]]
    to_2020 = [[0.6274, 0.3293, 0.0433], [0.0691, 0.9195, 0.0114], [0.0164, 0.0880, 0.8956]]
    np.testing.assert_allclose(colour.rgb_to_xyz_matrix(colour.SRGB_PRIMARIES), srgb_xyz, atol=5e-5)
    np.testing.assert_allclose(display.SRGB_TO_REC2020, to_2020, atol=5e-5)
    np.testing.assert_allclose(colour.rgb_to_xyz_matrix(colour.SRGB_PRIMARIES)[1], colour.REC709_LUMINANCE,
                               atol=5e-5)
    # The same white: rgb (1, 1, 1) stays (1, 1, 1) from one space to the other.
    np.testing.assert_allclose(display.SRGB_TO_REC2020.sum(1), 1.0, atol=1e-14)


# ---- AgX in float64, against values derived by hand ------------------------------------------

def test_agx_matrices_keep_white():
    """Each row of the inset and the outset sums to 1 (white in, white out); the outset is the
    published inverse's inverse."""
    np.testing.assert_allclose(display.AGX_INSET.sum(1), 1.0, atol=1e-14)
    np.testing.assert_allclose(display.AGX_OUTSET.sum(1), 1.0, atol=1e-13)
    np.testing.assert_allclose(display.AGX_IN @ np.ones(3), 1.0, atol=1e-14)
    # The inset pulls a primary toward white: Rec. 2020 red keeps 0.857 of its own channel.
    np.testing.assert_allclose(display.AGX_INSET @ [1.0, 0.0, 0.0], [0.856627, 0.137319, 0.111898], atol=1e-6)


def test_agx_log_encoding_spans_ten_stops_under_and_six_and_a_half_over_middle_grey():
    enc = display.agx_log_encoding(np.array([0.18 * 2.0 ** -10, 0.18, 0.18 * 2.0 ** 6.5, 1e-30, 1e30]))
    np.testing.assert_allclose(enc, [0.0, 10 / 16.5, 1.0, 0.0, 1.0], atol=1e-15)
    assert display.AGX_MIN_EV == pytest.approx(-12.47393, abs=1e-5)   # as Filament and three.js write it
    assert display.AGX_MAX_EV == pytest.approx(4.026069, abs=1e-6)


def test_agx_on_grey_is_the_one_dimensional_curve():
    """Every matrix keeps white, so on grey AgX is sigmoid(log encoding)^2.2 per value: middle
    grey lands on 20/33 of the log range, where the sigmoid is 0.4967306 (the fractions above),
    0.2145192 linear; from 0.18 x 2^6.5 up it is the sigmoid's top, 0.99858^2.2 = 0.9968787."""
    assert display.tonemap(grey(0.18), "agx") == pytest.approx([sigmoid(Fraction(20, 33)) ** 2.2] * 3, abs=1e-12)
    assert sigmoid(Fraction(20, 33)) ** 2.2 == pytest.approx(0.2145192, abs=1e-7)
    assert sigmoid(Fraction(1)) == pytest.approx(0.99858, abs=1e-15)
    for x in (0.18 * 2.0 ** 6.5, 100.0, 1e4):
        assert display.tonemap(grey(x), "agx") == pytest.approx([0.99858 ** 2.2] * 3, abs=1e-12)
    for x in 10.0 ** np.linspace(-3.7, 1.2, 50):   # inside the log range: the polynomial, clipped at 0
        t = Fraction((np.log2(x) - display.AGX_MIN_EV) / (display.AGX_MAX_EV - display.AGX_MIN_EV))
        assert display.tonemap(grey(x), "agx") == pytest.approx([max(sigmoid(t), 0.0) ** 2.2] * 3, abs=1e-12)


def test_agx_black_stays_black_and_grey_rises_monotonically():
    # The sigmoid starts below 0 (-0.00232); the outset's result is clipped at 0 before the power.
    assert display.tonemap(np.zeros(3), "agx").tolist() == [0.0, 0.0, 0.0]
    assert display.tonemap(grey(0.18 * 2.0 ** -10), "agx").tolist() == [0.0, 0.0, 0.0]
    # Its derivative has no real root in 0..1, so the curve only rises there.
    roots = np.roots(np.polyder(np.array([float(c) for c in SIGMOID])))
    assert not any(abs(r.imag) < 1e-12 and 0 <= r.real <= 1 for r in roots)
    ramp = display.tonemap(10.0 ** np.linspace(-5, 4, 20000)[:, None] * np.ones(3), "agx")[:, 0]
    assert (np.diff(ramp) >= 0).all() and ramp[0] == 0.0 and ramp[-1] == pytest.approx(0.99858 ** 2.2)


def test_agx_takes_a_bright_saturated_colour_to_white():
    """sRGB red goes paler with each stop (its other channels rise toward it) and is white once
    every channel after the inset is past the log range's top: the inset's smallest share of
    red, 0.0888, times 2^8 is past 0.18 x 2^6.5 = 16.3 (times 2^7 it is not)."""
    red = np.array([display.tonemap(np.array([2.0 ** ev, 0.0, 0.0]), "agx") for ev in range(-4, 9)])
    assert (red[:-1, 0] > red[:-1, 1:].max(1)).all()
    paleness = red[:, 1:].min(1) / red[:, 0]
    assert (np.diff(paleness) >= 0).all()
    assert (display.AGX_IN @ [2.0 ** 8, 0, 0]).min() > 0.18 * 2 ** 6.5 > (display.AGX_IN @ [2.0 ** 7, 0, 0]).min()
    assert red[-1] == pytest.approx([0.99858 ** 2.2] * 3, abs=1e-12)


# ---- AgX's GLSL against its float64 function ---------------------------------------------------

def _display_pass(session, name, values):
    import moderngl
    ctx = session.ctx
    hdr = np.ones((1, len(values), 4), np.float32)
    hdr[0, :, :3] = values
    program = session.programs.fragment(compose_program("display_main.glsl",
                                                        display_options(make_spec(tonemap=name, cell_borders=False))))
    radiance = ctx.texture((len(values), 1), 4, hdr.tobytes(), dtype="f4")
    target = ctx.texture((len(values), 1), 4, dtype="f4")
    ctx.framebuffer([target]).use()
    radiance.use(0)
    set_uniforms(program, {"u_radiance": 0, "u_exposure_scale": 1.0, "u_reinhard_white": 4.0})
    ctx.vertex_array(program, []).render(moderngl.TRIANGLES, vertices=3)
    return np.frombuffer(target.read(), np.float32).reshape(len(values), 4)[:, :3], hdr[0, :, :3]


def test_agx_glsl_matches_float64_over_greys_and_saturated_colours(ctx, session):
    """1e-4 to 1e3, greys, colours and colours with a channel at 0: the sRGB-encoded output
    within 2e-5 of the float64 function's (the bound every tone mapper meets in
    test_shading.py), greys grey."""
    rng = np.random.default_rng(3)
    values = 10.0 ** rng.uniform(-4, 3, (3000, 3))
    values[:1000] = values[:1000, :1]
    values[1000:2000, 0] = 0.0
    got, sent = _display_pass(session, "agx", values)
    want = display.srgb_oetf(display.tonemap(sent.astype(np.float64), "agx"))
    np.testing.assert_allclose(got, want, atol=2e-5)
    assert np.ptp(got[:1000], axis=1).max() < 2e-5


def test_an_agx_chart_is_its_radiance_through_the_float64_display(session):
    spec = make_spec(width=96, height=96, rows=2, cols=2, quality="draft", tonemap="agx", exposure=1.0)
    res = session.render(spec)
    assert display_error(res.hdr, res.alpha, res.image, spec)[1] == 0
