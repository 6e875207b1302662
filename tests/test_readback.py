"""A render reads back only what is asked: the display image always, linear radiance and the
AOVs on request (or, through the API, on first use), from targets the session keeps."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

import sdfpbr
from sdfpbr.gpu.frame import TargetPool
from sdfpbr.gpu.session import Session
from sdfpbr.spec.chart_spec import make_spec

SMALL = dict(width=64, height=48, rows=2, cols=3, quality="draft")


def test_the_image_alone_is_read_unless_more_is_asked(session):
    spec = make_spec(**SMALL)
    bare = session.render(spec, aovs=False, hdr=False)
    full = session.render(spec, aovs=True, hdr=True)
    assert bare.hdr is None and bare.alpha is None and bare.aov == {}
    np.testing.assert_array_equal(bare.image, full.image)   # the same draw, less read back
    assert full.hdr.shape == (48, 64, 3) and set(full.aov) >= {"normal", "depth", "row", "col", "coverage"}


def test_the_api_reads_hdr_and_aovs_lazily_and_gets_the_same_pixels(session):
    eager = sdfpbr.chart(**SMALL, hdr=True, aovs=True, session=session)
    lazy = sdfpbr.chart(**SMALL, session=session)
    assert lazy.result.hdr is None and lazy.result.aov == {}
    np.testing.assert_array_equal(lazy.hdr, eager.hdr)      # first use renders again: same pixels
    assert lazy.result.hdr is not None                       # and keeps what it read
    for name, values in eager.aov.items():
        np.testing.assert_array_equal(lazy.aov[name], values)
    np.testing.assert_array_equal(lazy.image, eager.image)


def test_saving_hdr_and_aovs_from_a_lazy_chart(session, tmp_path):
    lazy = sdfpbr.chart(**SMALL, session=session)
    lazy.save(tmp_path / "c.png", hdr=tmp_path / "c.npy", aov=tmp_path / "c.npz")
    eager = sdfpbr.chart(**SMALL, hdr=True, aovs=True, session=session)
    np.testing.assert_array_equal(np.load(tmp_path / "c.npy"), eager.hdr)
    with np.load(tmp_path / "c.npz") as aov:
        np.testing.assert_array_equal(aov["depth"], eager.aov["depth"])


def test_kept_targets_stay_within_the_pool_budget(session):
    with session:
        pool = TargetPool(session.ctx, budget=3 * 64 * 64 * 16)   # three 64² float RGBA textures
        taken = [pool.take(64, 64, "f4") for _ in range(5)]
        for tex in taken:
            pool.give(tex)
        again = pool.take(64, 64, "f4")
        assert again in taken                                   # reused, not made anew
        pool.give(again)
        assert pool.kept() == {(64, 64, "f4"): 3}
        big = pool.take(256, 256, "f4")                         # over budget by itself: not kept
        pool.give(big)
        assert pool.kept() == {(64, 64, "f4"): 3}
        pool.release()


def test_reads_land_in_kept_arrays_within_their_budget(session):
    with session:
        pool = TargetPool(session.ctx, staging_budget=2 * 64 * 64 * 16)   # two 64² float RGBA arrays
        a = pool.staging(64, 64, np.float32)
        assert pool.staging(64, 64, np.float32) is a                      # kept, not made anew
        b = pool.staging(64, 64, np.float32, slot=1)                      # another slot: its own
        assert b is not a and b.shape == (64, 64, 4) and b.dtype == np.float32
        pool.staging(64, 64, np.float16)                                  # third array: the oldest goes
        assert pool.staging(64, 64, np.float32) is not a
        big = pool.staging(128, 128, np.float32)                          # over budget alone: not kept
        assert pool.staging(128, 128, np.float32) is not big


def test_a_render_owns_its_arrays_when_the_next_reads_through_the_same_arrays(session):
    """The reads go through the session's kept arrays; what a render returns is its own copy."""
    own = Session(session.ctx, session.cache)
    a = own.render(make_spec(**SMALL, metallic=(1.0, 1.0)), hdr=True, aovs=True)
    kept = {name: np.array(v) for name, v in [("image", a.image), ("hdr", a.hdr), *a.aov.items()]}
    own.render(make_spec(**SMALL, roughness=(0.9, 0.9), ground=False), hdr=True, aovs=True)
    for name, values in [("image", a.image), ("hdr", a.hdr), *a.aov.items()]:
        np.testing.assert_array_equal(values, kept[name], err_msg=name)


def test_reused_targets_do_not_leak_one_render_into_the_next(session):
    """A kept target holds the last render's pixels; the next render must cover all of them
    (the background and a smaller chart included)."""
    own = Session(session.ctx, session.cache)
    a = own.render(make_spec(**SMALL, metallic=(1.0, 1.0)))
    b = own.render(make_spec(**SMALL, transparent=True, ground=False))
    fresh = Session(session.ctx, session.cache).render(make_spec(**SMALL, transparent=True, ground=False))
    np.testing.assert_array_equal(b.image, fresh.image)
    np.testing.assert_array_equal(b.hdr, fresh.hdr)
    assert not np.array_equal(a.image, b.image)


def test_the_api_draws_the_render_into_its_labelled_chart(session, tmp_path):
    """sdfpbr.chart() draws the render straight into the labelled chart's render area (an
    8192² chart holds one image, not two): the result is the chart that labelling a separate
    render composes, pixel for pixel, and the render is the chart's render area; glTF names are
    drawn over it, a chart without labels is the render."""
    from sdfpbr.image.chart_labels import label
    cases = [dict(SMALL), dict(SMALL, transparent=True), dict(SMALL, labels=False)]
    if importlib.util.find_spec("pygltflib"):   # the gltf extra
        cases.append(dict(width=96, height=64, gltf=str(Path(__file__).parents[1] / "charts" / "materials.glb")))
    for options in cases:
        spec = make_spec(**options)
        chart = sdfpbr.chart(spec, session=session)
        separate = session.render(spec, aovs=False, hdr=False)
        np.testing.assert_array_equal(chart.image, label(spec, separate))
        np.testing.assert_array_equal(chart.result.image, separate.image)
        if spec.labels and not spec.gltf:
            assert np.shares_memory(chart.result.image, chart.image)
    with pytest.raises(ValueError, match="to draw into"):
        session.render(make_spec(**SMALL), image=np.zeros((48, 63, 4), np.uint8))
