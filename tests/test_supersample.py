"""A supersampled pixel: its samples are centred strata of the pixel box (the reference's
footprint), and they come through a software rasterizer's loop limit whole. llvmpipe ends every
loop of a shader invocation, silently, once all of its loops together have turned 65535 times
(shaders/loop_guard.glsl): a pixel's samples are drawn over as many draws as that takes, adding
up to what one draw would give; a chart whose single ray is past the limit is refused rather
than drawn wrong."""
import dataclasses

import numpy as np
import pytest

from sdfpbr.errors import SpecError
from sdfpbr.gpu.render import sample_lattice_step
from sdfpbr.gpu.session import SOFTWARE_RENDERERS, Session
from sdfpbr.shading.plan import render_plan
from sdfpbr.spec import presets
from sdfpbr.spec.chart_spec import Light, make_spec

# At the high preset a floor pixel beside a rough sphere runs well over 1000 loop turns a sample
# (its bounce rays each integrate the environment), so 64 samples in one invocation pass 65535.
HEAVY = dict(rows=1, cols=2, roughness=(1.0, 1.0), quality="high", spp=64, width=64, height=32)


@pytest.fixture(scope="module")
def compute(session):
    """The compute variant on the same context, in tiles smaller than the image."""
    return Session(session.ctx, session.cache, chart_shader="compute", tile=32)


def draw_per(s: Session, spec, per_draw: int | None) -> Session:
    """``s`` having learnt nothing of its loop limit yet, or drawing ``per_draw`` of a pixel's
    samples at a time."""
    s.samples_per_draw.clear()
    if per_draw is not None:
        plan = render_plan(spec)
        for source in (plan.chart, plan.chart_compute):
            s.samples_per_draw[source.digest] = per_draw
    return s


def software(session) -> bool:
    return any(name in session.renderer.lower() for name in SOFTWARE_RENDERERS)


@pytest.fixture(scope="module")
def heavy(session):
    """The heavy chart as a session that has learnt nothing of its loop limit draws it, and
    what the session learnt: one render (~4 CPU s on llvmpipe) for the three tests below."""
    spec = make_spec(**HEAVY)
    chosen = draw_per(session, spec, None).render(spec)
    learned = dict(session.samples_per_draw)
    session.samples_per_draw.clear()
    return chosen, learned


@pytest.mark.parametrize("stage", ["fragment", "compute"])
def test_a_heavy_supersampled_chart_adds_up_to_its_samples_drawn_one_at_a_time(request, session, compute, stage):
    """One sample a draw keeps every invocation to one ray's loops, far under the limit; the
    chart drawn as the session chooses must agree with it to float rounding (the sums run in
    another order). Before the draws were split, llvmpipe's one draw lost the floor's bounce
    light in half the pixels here (up to 36 % dark). The compute variant adds its draws in its
    images, here in tiles."""
    s = session if stage == "fragment" else compute
    spec = make_spec(**HEAVY)
    chosen = request.getfixturevalue("heavy")[0] if s is session else draw_per(s, spec, None).render(spec)
    one_by_one = draw_per(s, spec, 1).render(spec)
    np.testing.assert_allclose(chosen.hdr, one_by_one.hdr, rtol=1e-4, atol=1e-6 * float(one_by_one.hdr.max()))
    np.testing.assert_allclose(chosen.alpha, one_by_one.alpha, atol=1e-5)
    for name in one_by_one.aov:   # the centre's hit, the samples' coverage
        np.testing.assert_allclose(chosen.aov[name], one_by_one.aov[name], atol=1e-5, err_msg=name)
    s.samples_per_draw.clear()


def test_the_floor_of_a_heavy_supersampled_chart_is_its_one_sample_floor(session, heavy):
    """An independent check of the same: the floor is smooth beside the sphere, so the mean of
    64 points of each pixel's box is the pixel-centre value within the floor's change across a
    pixel (< 1 % here, away from the silhouettes and the shadow's edge)."""
    spec = make_spec(**HEAVY)
    many = heavy[0]
    one = session.render(dataclasses.replace(spec, spp=1))
    floor = (one.aov["coverage"] == 0) & (many.aov["coverage"] == 0)
    # away from any edge: the pixel and its 8 neighbours all floor
    core = floor.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            core &= np.roll(np.roll(floor, dy, 0), dx, 1)
    def lum(r):
        return r.hdr @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    ratio = lum(many)[core] / lum(one)[core]
    assert core.sum() > 200
    assert np.percentile(ratio, 5) > 0.97, np.percentile(ratio, [0, 5, 50])
    session.samples_per_draw.clear()


def test_the_session_remembers_how_many_samples_a_draw_may_take(session, heavy):
    _, learned = heavy
    if software(session):   # 64 in one draw were cut; a quarter or less were not
        assert len(learned) == 1 and 1 <= list(learned.values())[0] <= 16
    else:
        assert learned == {}


def test_a_supersampled_half_float_chart_adds_up_in_float32(session):
    """Its draws' partial sums would each round in a half-float target, and a light over the
    half range (65504) would add up to Inf: a supersampled chart's radiance target is float32
    whatever hdr_precision says, and so draws what a float32 chart draws."""
    sun = Light("directional", direction=(-0.3, 0.8, 0.5), intensity=2e5, angular_radius_deg=1.0)
    spec = make_spec(rows=1, cols=1, roughness=(0.0, 0.0), metallic=(1.0, 1.0), lights=(sun,), width=32,
                     height=32, quality="draft", spp=4, hdr_precision="float16")
    half = draw_per(session, spec, 1).render(spec)
    full = draw_per(session, spec, 1).render(dataclasses.replace(spec, hdr_precision="float32"))
    assert np.isfinite(half.hdr).all() and half.hdr.max() > 65504
    np.testing.assert_array_equal(half.hdr, full.hdr)
    session.samples_per_draw.clear()


def test_a_chart_past_the_limit_with_one_ray_a_pixel_is_refused(session, monkeypatch):
    """More environment samples per pixel than the limit, in one ray: llvmpipe cannot draw it
    (it would cut the loop at 65535 and come out dark), so it says so; a GPU draws it."""
    # default's preset with high's per-pixel sampling, past the limit (high's own 512² bakes
    # would add 8 s and nothing to the claim)
    heavy = dataclasses.replace(presets.QUALITY_PRESETS["default"], ibl_method="sampled", ibl_pixel_samples=70000)
    monkeypatch.setitem(presets.QUALITY_PRESETS, "default", heavy)
    spec = make_spec(rows=1, cols=1, quality="default", width=16, height=16)
    if software(session):
        with pytest.raises(SpecError, match=r"more loop turns per pixel than the .* renderer runs \(\d+ pixels"):
            session.render(spec)
    else:
        session.render(spec)


@pytest.mark.parametrize("spp", [2, 3, 4, 8, 13, 64])
def test_the_samples_of_a_pixel_are_centred_strata(spp):
    """Each axis of the lattice holds every (k + 1/2) / spp once: the samples' mean is the
    pixel's centre, as the box the reference integrates."""
    g = sample_lattice_step(spp)
    assert np.gcd(g, spp) == 1
    i = np.arange(spp)
    for axis in (i, i * g % spp):
        assert sorted(axis.tolist()) == list(range(spp))


@pytest.mark.parametrize("spp", [2, 4, 8])
def test_a_supersampled_sphere_sits_where_its_exact_coverage_puts_it(session, spp):
    """The centroid of a sphere's sampled coverage against that of its analytic coverage (the
    pixel box's exact share, spp 1): the R2 points from the centre had their mean 0.12-0.22 px
    below and left of it, shifting the whole image against its reference by that much. The
    sampled rim's own error (under 1 / spp of a pixel on ~120 rim pixels, of both signs round
    the circle) moves the centroid by ~0.005 px: 0.03 px is a sixth of the old shift."""
    spec = make_spec(rows=1, cols=1, width=48, height=48, quality="draft")
    exact = session.render(spec).aov["coverage"].astype(np.float64)
    sampled = session.render(dataclasses.replace(spec, spp=spp)).aov["coverage"].astype(np.float64)
    y, x = np.mgrid[:48, :48]
    for c in (x, y):
        assert abs((c * sampled).sum() / sampled.sum() - (c * exact).sum() / exact.sum()) < 0.03
