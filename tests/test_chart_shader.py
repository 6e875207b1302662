"""The chart as a compute shader (for GPUs that run few fragment units) draws what the fragment
shader draws; which one a session uses follows its renderer, or $SDFPBR_CHART_SHADER."""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from sdfpbr.errors import SpecError
from sdfpbr.gpu.session import Session, chart_shader_for
from sdfpbr.spec.chart_spec import make_spec

CASES = [dict(), dict(stage="shared"), dict(spp=4), dict(hdr_precision="float16"), dict(transparent=True),
         dict(intersect="march"), dict(alpha=(0.3, 1.0), x_axis="alpha"), dict(width=330, height=250)]


@pytest.fixture(scope="module")
def shaders(sibling):
    return sibling(chart_shader="fragment"), sibling(chart_shader="compute")


@pytest.mark.parametrize("options", CASES, ids=[",".join(c) or "default" for c in CASES])
def test_the_compute_chart_is_the_fragment_chart(shaders, options):
    """The same source with another entry point: the same arithmetic per pixel, so the same
    radiance up to how the driver groups pixels for SIMD (llvmpipe takes some cube-map
    decisions per group: a few ulps), so the 8-bit images within one step (a few ulps can round
    a value either side of a step) and the same AOVs."""
    fragment, compute = shaders
    spec = make_spec(**{"width": 160, "height": 120, "quality": "draft", **options})
    a, b = fragment.render(spec), compute.render(spec)
    np.testing.assert_allclose(b.hdr, a.hdr, rtol=0, atol=1e-5 * a.hdr.max())
    np.testing.assert_allclose(b.alpha, a.alpha, rtol=0, atol=1e-6)
    assert np.abs(a.image.astype(int) - b.image.astype(int)).max() <= 1
    for name in a.aov:
        np.testing.assert_allclose(b.aov[name], a.aov[name], atol=1e-6, err_msg=name)


def test_the_compute_chart_tiles_and_reads_only_what_is_asked(sibling):
    spec = make_spec(width=150, height=90, rows=2, cols=3, quality="draft")
    whole = sibling(chart_shader="compute").render(spec)
    tiled = sibling(chart_shader="compute", tile=40).render(spec)
    np.testing.assert_allclose(tiled.hdr, whole.hdr, rtol=0, atol=1e-5 * whole.hdr.max())
    bare = sibling(chart_shader="compute").render(spec, aovs=False, hdr=False)
    assert bare.aov == {} and bare.hdr is None
    np.testing.assert_array_equal(bare.image, whole.image)


def test_the_shader_follows_the_renderer_or_the_environment(monkeypatch):
    monkeypatch.delenv("SDFPBR_CHART_SHADER", raising=False)
    assert chart_shader_for("llvmpipe (LLVM 15.0.6, 256 bits) | 4.5 (Core Profile) Mesa 22.3.6") == "fragment"
    assert chart_shader_for("NVIDIA H100 80GB HBM3/PCIe/SSE2 | 4.6.0 NVIDIA 550.54") == "compute"
    monkeypatch.setenv("SDFPBR_CHART_SHADER", "compute")
    assert chart_shader_for("llvmpipe") == "compute"
    monkeypatch.setenv("SDFPBR_CHART_SHADER", "vertex")
    with pytest.raises(SpecError, match="SDFPBR_CHART_SHADER must be one of fragment, compute"):
        chart_shader_for("llvmpipe")


DATA = Path(__file__).parent / "data"


# Layouts where a ring could miss a silhouette pixel: tiny spheres (whole discs), wide cells,
# tiles the rings cross, the shared stage's spheres seen from round and above, orthographic,
# a camera backed off, glTF-style see-through and textured spheres.
EDGE_CASES = [dict(), dict(width=256, height=256, rows=64, cols=64), dict(width=600, height=110, rows=1, cols=11),
              dict(width=333, height=271, rows=3, cols=4, tile=64), dict(stage="shared", camera_azimuth=20.0,
              camera_elevation=25.0), dict(stage="shared", rows=2, cols=7, width=420, height=160),
              dict(camera="orthographic"), dict(camera_distance_scale=1.7), dict(textures="procedural"),
              dict(alpha=(0.3, 1.0), x_axis="alpha"), dict(transparent=True),
              # no sphere prepass (every cell its own material): the sphere pass too
              dict(y_axis="clearcoat", sheen_color=(0.6, 0.3, 0.4), ior=2.0),
              dict(row_materials=("gold", "copper", "silver"), rows=3, cols=4, transparent=True),
              dict(gltf=str(DATA.parent.parent / "charts" / "materials.glb"), width=300, height=200),
              dict(y_axis="clearcoat", width=256, height=256, rows=20, cols=20),
              # the covered part in four samples (high's): the sphere prepass's, the sphere pass's,
              # the shared stage's and a see-through sphere's edges
              dict(edge_samples=4), dict(edge_samples=4, y_axis="clearcoat", sheen_color=(0.6, 0.3, 0.4), ior=2.0),
              dict(edge_samples=4, stage="shared", rows=2, cols=7, width=420, height=160),
              dict(edge_samples=4, alpha=(0.3, 1.0), x_axis="alpha")]


@pytest.mark.parametrize("options", EDGE_CASES, ids=[",".join(f"{k}={v}" for k, v in c.items()) or "default"
                                                     for c in EDGE_CASES])
def test_the_edge_pass_draws_what_the_chart_draws_inline(sibling, monkeypatch, options):
    """The fragment chart leaves its silhouettes' pixels to a pass over a ring of triangles
    round each one (a software rasterizer runs an if's body for every pixel): every pixel the
    silhouette crosses must lie in a ring, and the pass must shade it as the chart program
    does inline. Same arithmetic per pixel: the same radiance, coverage and AOVs."""
    from sdfpbr.gpu.render import render_chart
    from sdfpbr.shading.plan import render_plan
    from sdfpbr.spec.presets import QUALITY_PRESETS
    options = dict(options)
    tile = options.pop("tile", None)
    if "edge_samples" in options:
        monkeypatch.setitem(QUALITY_PRESETS, "draft", dataclasses.replace(QUALITY_PRESETS["draft"],
                                                                          edge_samples=options.pop("edge_samples")))
    spec = make_spec(**{"width": 256, "height": 256, "quality": "draft", **options})
    plan = render_plan(spec, passes=True)
    assert plan.edge_pass is not None and plan.options["EDGE_PIXELS"] == "skipped"
    assert (plan.sphere_pass is not None) == (plan.options["STAGE"] == "cells" and not plan.options["SPHERE_PREPASS"])
    fragment = sibling(chart_shader="fragment", tile=tile)
    with fragment:
        a = render_chart(fragment, spec, plan=render_plan(spec, passes=False))
        b = render_chart(fragment, spec, plan=plan)
    edges = (a.aov["coverage"] > 0) & (a.aov["coverage"] < 1)
    assert edges.sum() > 0
    np.testing.assert_allclose(b.hdr, a.hdr, rtol=0, atol=1e-6 * a.hdr.max())
    np.testing.assert_array_equal(b.alpha, a.alpha)
    np.testing.assert_array_equal(b.image, a.image)
    for name in a.aov:
        np.testing.assert_allclose(b.aov[name], a.aov[name], rtol=0, atol=1e-6, err_msg=name)


def test_a_ring_too_thin_for_the_silhouette_leaves_pixels_out(session, monkeypatch):
    """The comparison above can fail: rings a third of a pixel wide miss silhouette pixels,
    which then keep the chart pass's one ray (coverage 0 or 1)."""
    import sdfpbr.gpu.render as render
    import sdfpbr.shading.plan as planning
    edge_rings = planning.edge_rings
    spec = make_spec(width=256, height=256, quality="draft")
    plan = render.render_plan(spec, passes=True)
    fragment = Session(session.ctx, session.cache, chart_shader="fragment")
    with fragment:
        a = render.render_chart(fragment, spec, plan=render.render_plan(spec, passes=False))
        monkeypatch.setattr(planning, "edge_rings", lambda frame: edge_rings(frame, pad=0.15))
        b = render.render_chart(fragment, spec, plan=plan)   # its rings made now, at its first draw
    edges = (a.aov["coverage"] > 0) & (a.aov["coverage"] < 1)
    missed = edges & ((b.aov["coverage"] == 0) | (b.aov["coverage"] == 1))
    assert missed.sum() > 0.2 * edges.sum()


def test_boxes_too_small_for_the_spheres_leave_them_unshaded(session, monkeypatch):
    """The comparison above can fail for the sphere pass too: boxes cut 10 px inside the
    silhouettes leave sphere pixels with the chart pass's value (no sphere shaded there)."""
    import sdfpbr.gpu.render as render
    import sdfpbr.shading.plan as planning
    sphere_boxes = planning.sphere_boxes
    spec = make_spec(width=256, height=256, quality="draft", y_axis="clearcoat")
    plan = render.render_plan(spec, passes=True)
    assert plan.sphere_pass is not None
    fragment = Session(session.ctx, session.cache, chart_shader="fragment")
    with fragment:
        a = render.render_chart(fragment, spec, plan=render.render_plan(spec, passes=False))
        monkeypatch.setattr(planning, "sphere_boxes", lambda frame: sphere_boxes(frame, pad=-10.0))
        b = render.render_chart(fragment, spec, plan=plan)   # its boxes made now, at its first draw
    spheres = a.aov["coverage"] == 1
    dark = spheres & (b.hdr.max(axis=-1) == 0) & (a.hdr.max(axis=-1) > 0)
    assert dark.sum() > 0.2 * spheres.sum()


def test_a_sphere_pass_without_an_edge_pass_draws_the_edges_itself(sibling):
    """Between the two passes' sizes (SPHERE_PASS_MIN_PIXELS, EDGE_PASS_MIN_PIXELS) a chart
    without the sphere prepass has a sphere pass alone, which draws the silhouettes' pixels too."""
    from sdfpbr.gpu.render import render_chart
    from sdfpbr.shading.plan import render_plan
    spec = make_spec(width=600, height=500, rows=3, cols=4, quality="draft", y_axis="clearcoat")
    plan = render_plan(spec)
    assert plan.sphere_pass is not None and plan.edge_pass is None
    fragment = sibling(chart_shader="fragment")
    with fragment:
        a = render_chart(fragment, spec, plan=render_plan(spec, passes=False))
        b = render_chart(fragment, spec, plan=plan)
    assert ((a.aov["coverage"] > 0) & (a.aov["coverage"] < 1)).sum() > 0
    np.testing.assert_allclose(b.hdr, a.hdr, rtol=0, atol=1e-6 * a.hdr.max())
    np.testing.assert_array_equal(b.image, a.image)
    for name in a.aov:
        np.testing.assert_allclose(b.aov[name], a.aov[name], rtol=0, atol=1e-6, err_msg=name)


@pytest.mark.parametrize("options, edges, spheres", [
    (dict(width=1024, height=1024), True, False),            # the default: the sphere prepass
    (dict(width=512, height=512), False, False),             # too small to earn a program back
    (dict(width=768, height=768, y_axis="clearcoat"), True, True),
    (dict(width=600, height=500, y_axis="clearcoat"), False, True),
    (dict(width=1024, height=1024, stage="shared"), True, False),   # no sphere pass there
    (dict(width=1024, height=1024, spp=4), False, False),    # no analytic edge: all inline
])
def test_passes_where_they_earn_their_programs(options, edges, spheres):
    from sdfpbr.shading.plan import render_plan
    plan = render_plan(make_spec(**options))
    assert (plan.edge_pass is not None, plan.sphere_pass is not None) == (edges, spheres)
    assert (plan.instances_vertex is not None) == (edges or spheres)
