"""Alpha modes (glTF alphaMode): a blend sphere is laid over what lies behind it by its alpha,
a mask sphere is cut out below its cutoff, opaque ignores alpha; by factor, by the base colour
map's alpha and in the reference. Alpha is coverage for the light too: a sphere stops its
alpha's share of the light, so its floor is the shadowed floor (shadow, occlusion, bounce) in
that share and the open floor in the rest. The identities the tests check follow from that
definition alone: the floor a blend sphere leaves is linear in alpha between the opaque
sphere's and the alpha-0 render's, and a pixel that sees the sphere adds the floor behind it
in 1 - alpha; the closed form of a sun's light on the floor, thinned by 1 - alpha in the
shadow, holds in the chart and the reference."""
import numpy as np
import pytest

from sdfpbr.errors import SpecError
from sdfpbr.spec.chart_spec import make_spec

BASE = dict(rows=1, cols=1, size="128x128", labels=False, roughness=(0.3, 0.3))
# float32 radiance through the same arithmetic: a mix of two values differs from the value
# mixed in the shader by rounding only (a few ulp); the HDR target stores float32.
RTOL, ATOL = 1e-5, 1e-6


def hdr(session, **kw):
    return session.render(make_spec(**{**BASE, **kw})).hdr.astype(np.float64)


@pytest.mark.parametrize("stage", ["cells", "shared"])
def test_blend_lays_the_sphere_over_a_floor_it_shadows_by_its_alpha(session, stage):
    """A blend sphere of alpha a: the floor beside it is a (opaque floor) + (1 - a) (alpha-0
    floor); a pixel that sees the sphere is a S + (1 - a) (a X + (1 - a) O), S the opaque
    sphere, O the open floor behind it (the alpha-0 render), X the floor behind it as the
    sphere shadows it (no render shows it: solved from a = 0.3, then a = 0.75 must agree).
    One sphere on either stage: on the shared one each sphere's share multiplies, linear in a
    only where one sphere alone hides the light."""
    opaque, empty = hdr(session, stage=stage), hdr(session, stage=stage, alpha=(0.0, 0.0))
    res = session.render(make_spec(**{**BASE, "stage": stage, "alpha": (0.3, 0.3)}))
    aov, low, high = res.aov, res.hdr.astype(np.float64), hdr(session, stage=stage, alpha=(0.75, 0.75))
    sphere, floor = aov["coverage"] == 1, aov["coverage"] == 0   # not the edge's blend of both
    # The alpha-0 render shows the open floor, the opaque one the sphere and its shadow.
    assert np.abs(opaque[sphere] - empty[sphere]).max() > 0.1 and np.abs(opaque[floor] - empty[floor]).max() > 0.01
    for a, got in ((0.3, low), (0.75, high)):
        np.testing.assert_allclose(got[floor], a * opaque[floor] + (1 - a) * empty[floor], rtol=RTOL, atol=ATOL)
    a, b = 0.3, 0.75
    shadowed = (low[sphere] - a * opaque[sphere] - (1 - a) ** 2 * empty[sphere]) / ((1 - a) * a)
    want = b * opaque[sphere] + (1 - b) * (b * shadowed + (1 - b) * empty[sphere])
    np.testing.assert_allclose(high[sphere], want, rtol=1e-4, atol=1e-5)   # the solve divides by 0.21


def test_mask_cuts_out_below_the_cutoff_and_keeps_the_rest_opaque(session):
    opaque, empty = hdr(session), hdr(session, alpha=(0.0, 0.0))
    kept = hdr(session, alpha=(0.6, 0.6), alpha_mode="mask", alpha_cutoff=0.5)
    cut = hdr(session, alpha=(0.4, 0.4), alpha_mode="mask", alpha_cutoff=0.5)
    np.testing.assert_allclose(kept, opaque, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(cut, empty, rtol=RTOL, atol=ATOL)
    # opaque ignores alpha
    np.testing.assert_allclose(hdr(session, alpha=(0.2, 0.2), alpha_mode="opaque"), opaque, rtol=RTOL, atol=ATOL)


def test_alpha_on_an_axis_blends_each_cell_by_its_own_value(session, monkeypatch):
    """The opaque cell (alpha 1) of an alpha axis is the opaque chart's cell. The bounce cache
    is held off: the see-through chart shades its spheres per point (2 x 2 a pixel here) and
    reads the gather prepass at each, the opaque chart's sphere prepass once a pixel (0.2 %
    apart); tests/test_stage.py checks the gather prepass itself."""
    import dataclasses
    from sdfpbr.spec.presets import QUALITY_PRESETS
    monkeypatch.setitem(QUALITY_PRESETS, "default",
                        dataclasses.replace(QUALITY_PRESETS["default"], bounce_iterations=0))
    spec = make_spec(rows=1, cols=3, size="192x64", labels=False, x_axis="alpha", y_axis="roughness",
                     roughness=(0.3, 0.3))
    assert [m.alpha_mode for m in spec.cell_materials()[0]] == ["blend", "blend", "opaque"]
    res = session.render(spec)
    aov, got = res.aov, res.hdr.astype(np.float64)
    opaque = session.render(make_spec(rows=1, cols=3, size="192x64", labels=False, roughness=(0.3, 0.3),
                                      metallic=(0.0, 0.0))).hdr.astype(np.float64)
    for col, alpha in enumerate((0.0, 0.5, 1.0)):
        sphere = (aov["col"] == col) & (aov["coverage"] == 1)
        if alpha == 1.0:
            np.testing.assert_allclose(got[sphere], opaque[sphere], rtol=RTOL, atol=ATOL)
        else:   # brighter or darker than the opaque cell by its blend, never equal to it
            assert np.abs(got[sphere] - opaque[sphere]).mean() > 0.01


@pytest.mark.parametrize("stage, intersect, precision", [("cells", "analytic", "float32"),
                                                     ("shared", "march", "float16"),
                                                     ("shared", "analytic", "float32")])
@pytest.mark.parametrize("alpha", [1e-6, 0.5, 1 - 1e-6])
def test_without_a_floor_a_blend_spheres_coverage_is_its_alpha(session, stage, intersect, precision, alpha):
    """Transparent, no floor: what lies behind a sphere is nothing (coverage 0), so a fully
    covered sphere pixel's coverage is alpha itself; radiance stays finite and non-negative on
    both stages, both intersectors and half floats (the half target: rtol 2^-11, and its
    smallest subnormal step, 2^-24, absolute: drivers may truncate when they convert)."""
    spec = make_spec(rows=2, cols=2, size="96x96", labels=False, ground=False, transparent=True, alpha=(alpha, alpha),
                     stage=stage, intersect=intersect, hdr_precision=precision)
    res = session.render(spec)
    hdr, coverage = res.hdr.astype(np.float64), res.alpha.astype(np.float64)
    assert np.isfinite(hdr).all() and (hdr >= 0).all() and (coverage >= 0).all() and (coverage <= 1).all()
    inside = res.aov["coverage"] == 1
    assert inside.sum() > 500
    np.testing.assert_allclose(coverage[inside], alpha, rtol=2.0 ** -11, atol=2.0 ** -24)


def test_the_reference_blends_by_the_same_alpha(session):
    """Emission only (no light, black sky, no floor): the opaque sphere is its emission E, so
    the blend sphere is alpha E over black. The reference sees past it with probability
    1 - alpha per camera path: over n samples of p pixels its mean is within 4 standard errors,
    E sqrt(alpha (1 - alpha) / (n p)), of alpha E."""
    from sdfpbr.features.reference import render_reference
    alpha, emission, samples = 0.35, np.array([1.0, 0.5, 0.25]), 64
    spec = make_spec(**BASE, alpha=(alpha, alpha), emissive=tuple(emission), base_color=(0.0, 0.0, 0.0),
                     env="black", ibl=False, ground=False, lights=())
    ref = render_reference(spec, samples=samples, seed=5, session=session)
    chart = session.render(spec)
    inside = chart.aov["coverage"] == 1
    pixels = int(inside.sum())
    got = ref.hdr[..., :3].astype(np.float64)[inside].mean(0)
    sigma = emission * np.sqrt(alpha * (1 - alpha) / (samples * pixels))
    assert np.all(np.abs(got - alpha * emission) <= 4 * sigma), (got, alpha * emission, sigma)
    np.testing.assert_allclose(chart.hdr[..., :3][inside], np.broadcast_to(alpha * emission, (pixels, 3)),
                               rtol=1e-4)


# ---- glTF -----------------------------------------------------------------------------------

pygltflib = pytest.importorskip("pygltflib", reason="the gltf extra (pygltflib) is not installed")
from helpers import PROGRAM_RTOL, floor_points, footprint_offsets, png_bytes, textured_glb  # noqa: E402


def glb_with_alpha(tmp_path, mode, factor_alpha=1.0, cutoff=None, left=0, right=255):
    """A white dielectric whose base colour map's alpha is `left` on the texture's left half
    (u < 0.5: the sphere's left half on screen) and `right` on its right half."""
    img = np.full((8, 16, 4), 255, np.uint8)
    img[:, :8, 3], img[:, 8:, 3] = left, right
    m = pygltflib.Material(name="leaf", alphaMode=mode, alphaCutoff=cutoff,
                           pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
                               baseColorFactor=[1.0, 1.0, 1.0, factor_alpha], metallicFactor=0.0,
                               roughnessFactor=0.3, baseColorTexture=pygltflib.TextureInfo(index=0)))
    return textured_glb(tmp_path / f"{mode}.glb", [png_bytes(img)], [m], [pygltflib.Sampler(magFilter=9728)])


@pytest.mark.parametrize("mode, factor, cutoff, left, right, want_left, want_right", [
    ("MASK", 1.0, 0.5, 0, 255, 0.0, 1.0),       # the left half cut out
    ("MASK", 0.6, 0.7, 255, 255, 0.0, 0.0),     # factor x texel below the cutoff everywhere
    ("BLEND", 0.5, None, 255, 102, 0.5, 0.2),   # factor x texel (alpha is linear: 102 / 255 = 0.4)
    ("OPAQUE", 0.2, None, 0, 0, 1.0, 1.0),      # alpha ignored
])
def test_gltf_alpha_modes_read_the_factor_and_the_maps_alpha(session, tmp_path, mode, factor, cutoff, left, right,
                                                              want_left, want_right):
    kw = dict(size="128x128", labels=False, ground=False)   # behind the sphere only the sky, which it cannot shadow
    got_res = session.render(make_spec(gltf=glb_with_alpha(tmp_path, mode, factor, cutoff, left, right), **kw))
    # The same sphere opaque, and with nothing in front (alpha 0 by factor).
    opaque = session.render(make_spec(gltf=glb_with_alpha(tmp_path, "OPAQUE"), **kw)).hdr.astype(np.float64)
    empty = session.render(make_spec(gltf=glb_with_alpha(tmp_path, "BLEND", 0.0), **kw)).hdr.astype(np.float64)
    got, aov = got_res.hdr.astype(np.float64), got_res.aov
    inside = aov["coverage"] == 1
    nx = aov["normal"][..., 0]
    for side, a in ((inside & (nx < -0.2), want_left), (inside & (nx > 0.2), want_right)):
        want = a * opaque[side] + (1 - a) * empty[side]
        # The map's alpha is filtered (8-bit, level of detail): within half a step of the texel.
        np.testing.assert_allclose(got[side], want, atol=0.5 / 255 * np.abs(opaque[side] - empty[side]).max() + 1e-5)


def test_a_masks_holes_thin_its_light_by_their_share(session, tmp_path):
    """Under the environment alone (no lights, so no shadow to pattern), a mask sphere cut out
    on its left half (the map's alpha) takes half the light an opaque one takes from the floor
    beside it: the floor is c (opaque floor) + (1 - c) (open floor) with c the share of the
    sphere kept, 1/2, read at LIGHT_COVERAGE_POINTS = 16 points (material.glsl): within one
    point's share, and the same everywhere."""
    kw = dict(size="128x128", labels=False, lights=())
    res = session.render(make_spec(gltf=glb_with_alpha(tmp_path, "MASK", 1.0, 0.5, 0, 255), **kw))
    opaque = session.render(make_spec(gltf=glb_with_alpha(tmp_path, "OPAQUE"), **kw)).hdr.astype(np.float64)
    empty = session.render(make_spec(gltf=glb_with_alpha(tmp_path, "BLEND", 0.0), **kw)).hdr.astype(np.float64)
    got = res.hdr.astype(np.float64)
    shade = (res.aov["coverage"] == 0) & (np.abs(opaque - empty).max(-1) > 0.02)
    assert shade.sum() > 100
    kept = ((got - empty)[shade] / (opaque - empty)[shade]).mean(-1)
    assert abs(np.median(kept) - 0.5) <= 1 / 16, np.median(kept)
    # The same share everywhere, to the rounding of the three renders' pixels (each its own
    # program: PROGRAM_RTOL of each value) carried through the ratio, here and at the median.
    rounding = (PROGRAM_RTOL * (np.abs(got) + 2 * np.abs(empty) + np.abs(opaque))[shade]
                / np.abs(opaque - empty)[shade]).max(-1)
    assert (np.abs(kept - np.median(kept)) <= rounding + rounding.max()).all()


@pytest.mark.parametrize("stage, direction", [("cells", (-0.5, 0.7, 0.5)), ("cells", (0.6, 0.6, 0.3)),
                                              ("shared", (-0.5, 0.7, 0.5))])
def test_a_masks_shadow_falls_in_its_pattern(session, tmp_path, stage, direction):
    """A sun alone (half a degree, black sky, no occlusion or bounce): the floor takes only the
    sun's light, and where an opaque sphere hides all of it, the mask sphere hides it where
    the sun's ray meets its kept half (x > 0, the map's right half) and lets it all through
    where the ray enters the cut-out half, as the reference's rays do. So the share of the
    opaque sphere's shadow on the floor is 1 or 0 by ray geometry, away from the cut (5% of a
    radius, the map read at level 0 and nearest); an even thinning by the mean would be 1/2."""
    sun = {"kind": "directional", "direction": list(direction), "intensity": 3.0, "angular_radius_deg": 0.5}
    kw = dict(size="128x128", labels=False, lights=[sun], env="black", ao=False, stage=stage)
    spec = make_spec(gltf=glb_with_alpha(tmp_path, "MASK", 1.0, 0.5, 0, 255), **kw)
    res = session.render(spec)
    opaque = session.render(make_spec(gltf=glb_with_alpha(tmp_path, "OPAQUE"), **kw)).hdr[..., :3].astype(np.float64)
    empty = session.render(make_spec(gltf=glb_with_alpha(tmp_path, "BLEND", 0.0), **kw)).hdr[..., :3].astype(np.float64)
    got = res.hdr[..., :3].astype(np.float64)
    points, pixel, floor = floor_points(spec, np.zeros((1, 3)))
    umbra = floor & (res.aov["coverage"] == 0) & (opaque.max(-1) < 0.01 * empty.max(-1))
    l = np.asarray(direction) / np.linalg.norm(direction)
    # The cells stage averages the floor's shadow over four points of the pixel's footprint;
    # the shared stage takes the pixel's centre.
    offsets = footprint_offsets(spec, points, pixel) if stage == "cells" else [np.zeros_like(points)]
    xs = []
    for offset in offsets:
        p = (points + offset)[umbra]
        b = p @ l     # the sphere (radius 1 at the origin): entry at t = -b - sqrt(b^2 - |p|^2 + 1)
        xs.append((p + (-b - np.sqrt(np.maximum(b * b - (p * p).sum(-1) + 1.0, 0.0)))[:, None] * l)[:, 0])
    xs = np.array(xs)
    # Away from the cut, every point's ray enters the same half.
    clear = (np.abs(xs) > 0.05).all(0) & ((xs > 0).all(0) | (xs < 0).all(0))
    side = xs[0] > 0
    assert clear.sum() > 50 and side[clear].any() and (~side[clear]).any()
    kept = ((got - empty)[umbra] / (opaque - empty)[umbra]).mean(-1)
    # 1 or 0 but for the three renders' rounding (PROGRAM_RTOL of each value) through the ratio.
    rounding = (PROGRAM_RTOL * (np.abs(got) + 2 * np.abs(empty) + np.abs(opaque))[umbra]
                / np.abs(opaque - empty)[umbra]).max(-1)
    assert (np.abs(kept - side)[clear] <= rounding[clear]).all()


def test_a_bad_alpha_mode_is_one_line(tmp_path):
    path = glb_with_alpha(tmp_path, "SEETHROUGH")
    with pytest.raises(SpecError, match="alphaMode 'SEETHROUGH' is not OPAQUE, MASK or BLEND"):
        make_spec(gltf=path)
