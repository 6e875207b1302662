"""The chart as a compute shader (for GPUs that run few fragment units) draws what the fragment
shader draws; which one a session uses follows its renderer, or $SDFPBR_CHART_STAGE."""
import numpy as np
import pytest

from sdfpbr.errors import SpecError
from sdfpbr.gpu.session import Session, chart_stage_for
from sdfpbr.spec.chart_spec import make_spec

CASES = [dict(), dict(stage="shared"), dict(spp=4), dict(hdr_precision="float16"), dict(transparent=True),
         dict(intersect="march"), dict(alpha=(0.3, 1.0), x_axis="alpha"), dict(width=330, height=250)]


@pytest.fixture(scope="module")
def stages(session):
    return Session(session.ctx, session.cache, chart_stage="fragment"), \
        Session(session.ctx, session.cache, chart_stage="compute")


@pytest.mark.parametrize("options", CASES, ids=[",".join(c) or "default" for c in CASES])
def test_the_compute_chart_is_the_fragment_chart(stages, options):
    """The same source with another entry point: the same arithmetic per pixel, so the same
    radiance up to how the driver groups pixels for SIMD (llvmpipe takes some cube-map
    decisions per group: a few ulps), the same 8-bit image and AOVs."""
    fragment, compute = stages
    spec = make_spec(**{"width": 160, "height": 120, "quality": "draft", **options})
    a, b = fragment.render(spec), compute.render(spec)
    np.testing.assert_allclose(b.hdr, a.hdr, rtol=0, atol=1e-5 * a.hdr.max())
    np.testing.assert_allclose(b.alpha, a.alpha, rtol=0, atol=1e-6)
    assert np.abs(a.image.astype(int) - b.image.astype(int)).max() <= 1
    for name in a.aov:
        np.testing.assert_allclose(b.aov[name], a.aov[name], atol=1e-6, err_msg=name)


def test_the_compute_chart_tiles_and_reads_only_what_is_asked(session):
    spec = make_spec(width=150, height=90, rows=2, cols=3, quality="draft")
    whole = Session(session.ctx, session.cache, chart_stage="compute").render(spec)
    tiled = Session(session.ctx, session.cache, chart_stage="compute", tile=40).render(spec)
    np.testing.assert_allclose(tiled.hdr, whole.hdr, rtol=0, atol=1e-5 * whole.hdr.max())
    bare = Session(session.ctx, session.cache, chart_stage="compute").render(spec, aovs=False, hdr=False)
    assert bare.aov == {} and bare.hdr is None
    np.testing.assert_array_equal(bare.image, whole.image)


def test_the_stage_follows_the_renderer_or_the_environment(monkeypatch):
    monkeypatch.delenv("SDFPBR_CHART_STAGE", raising=False)
    assert chart_stage_for("llvmpipe (LLVM 15.0.6, 256 bits) | 4.5 (Core Profile) Mesa 22.3.6") == "fragment"
    assert chart_stage_for("NVIDIA H100 80GB HBM3/PCIe/SSE2 | 4.6.0 NVIDIA 550.54") == "compute"
    monkeypatch.setenv("SDFPBR_CHART_STAGE", "compute")
    assert chart_stage_for("llvmpipe") == "compute"
    monkeypatch.setenv("SDFPBR_CHART_STAGE", "vertex")
    with pytest.raises(SpecError, match="SDFPBR_CHART_STAGE must be one of fragment, compute"):
        chart_stage_for("llvmpipe")
