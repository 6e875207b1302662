"""The cells stage's prepasses kept in the disk cache (gpu/prepasses.py): a chart drawn again reads
them instead of drawing them, and gets the same pixels; anything a prepass is drawn with that
changes is a prepass drawn anew; what has no key is drawn every time."""
import numpy as np
import pytest

from sdfpbr.cache import ArrayCache
from sdfpbr.gpu import prepasses
from sdfpbr.spec.chart_spec import Light, make_spec

BASE = dict(size="360x320", rows=4, cols=3, labels=False)   # all three prepasses (slots shared by 4 rows)


@pytest.fixture
def draws(monkeypatch):
    """The prepasses drawn (not read from the cache), by their program's name, as they happen."""
    drawn = []
    draw = prepasses._draw_prepass

    def counting(session, source, *args, **kwargs):
        drawn.append(next(m for m in source.modules if m.endswith("_main.glsl")))
        return draw(session, source, *args, **kwargs)
    monkeypatch.setattr(prepasses, "_draw_prepass", counting)
    return drawn


def with_cache(session, monkeypatch, root):
    """Prepasses go to (and come from) a cache of their own; the IBL bakes stay where they are."""
    monkeypatch.setattr(session, "cache", ArrayCache(root))
    return root


def prepass_draws(spec) -> int:
    """The prepasses a frame of ``spec`` draws: floor, bounce, gather and sphere prepasses where its
    plan has them, and one per draw of the bounce cache."""
    from sdfpbr.shading.plan import render_plan
    plan = render_plan(spec)
    drawn = (plan.floor_prepass, plan.bounce_prepass, plan.gather_prepass, plan.sphere_prepass)
    return (sum(s is not None for s in drawn)
            + plan.bounce_iterations)


def entries(root):
    return (sorted(p.name for p in (root / prepasses.PREPASS_KIND).glob("*.npz"))
            if (root / prepasses.PREPASS_KIND).is_dir() else [])


def assert_same_render(a, b):
    np.testing.assert_array_equal(a.hdr, b.hdr)
    np.testing.assert_array_equal(a.alpha, b.alpha)
    np.testing.assert_array_equal(a.image, b.image)
    for name in a.aov:
        np.testing.assert_array_equal(a.aov[name], b.aov[name])


def test_a_chart_drawn_again_reads_its_prepasses(session, monkeypatch, tmp_path, draws):
    root = with_cache(session, monkeypatch, tmp_path)
    spec = make_spec(**BASE)
    first = session.render(spec)
    n = prepass_draws(spec)
    assert n == 6 and len(draws) == n and len(entries(root)) == n   # floor, 2 cache, bounce, gather, sphere
    draws.clear()
    again = session.render(spec)
    assert draws == []
    assert_same_render(first, again)


@pytest.mark.parametrize("change", [
    dict(lights=(Light("directional", direction=(0.3, 0.7, 0.2)),)),   # the floor's shadow, the probe
    dict(ground_color=(0.4, 0.2, 0.1)),
    dict(roughness=(0.2, 0.9)),                                          # the slots
    dict(metallic=(0.0, 0.5)),                                           # the cells' table only
    dict(size="364x320"),
    dict(camera_azimuth=25.0),
    dict(quality="draft"),   # (high's 512² bakes, made twice here, took 14 of this test's 26 s)
    dict(bugs=("unsquared-roughness",)),                                 # another program
    dict(env="sky"),
    dict(transparent=True),                                              # the floor a shadow catcher
    dict(spp=4),
])
def test_a_changed_chart_draws_what_changed(session, monkeypatch, tmp_path, draws, change):
    """With the first chart's prepasses in the cache, a chart that differs in one field renders
    exactly as it does from an empty cache: no prepass it reads was made for the other chart."""
    with_cache(session, monkeypatch, tmp_path / "warm")
    session.render(make_spec(**BASE))
    spec = make_spec(**{**BASE, **change})
    draws.clear()
    warm = session.render(spec)
    assert draws, "every change here reaches a prepass"
    with_cache(session, monkeypatch, tmp_path / "empty")
    assert_same_render(warm, session.render(spec))


def test_prepasses_drawn_with_unkeyed_textures_are_not_kept(session, monkeypatch, tmp_path, draws):
    """Surface maps carry no content key: their chart's prepasses are drawn every time."""
    root = with_cache(session, monkeypatch, tmp_path)
    spec = make_spec(**BASE, textures="procedural")
    session.render(spec)
    assert draws and entries(root) == []


def test_a_uniform_the_scene_does_not_set_keeps_the_prepass_out(session, monkeypatch, tmp_path, draws):
    """A prepass program that reads a uniform missing from the scene's (its value is whatever an
    earlier draw left on the program) is drawn but not kept."""
    from sdfpbr.gpu import frame
    root = with_cache(session, monkeypatch, tmp_path)
    chart_uniforms = frame.chart_uniforms

    def without_ground(*args):
        values = dict(chart_uniforms(*args))
        values.pop("u_ground_color")          # read by the floor prepass
        return values
    monkeypatch.setattr(frame, "chart_uniforms", without_ground)
    session.render(make_spec(**BASE))
    assert len(draws) == prepass_draws(make_spec(**BASE)) and draws[0].endswith("floor_main.glsl")
    assert entries(root) == []   # nor the prepasses after it: their keys would hold its key


def test_prepasses_over_the_size_cap_are_drawn_every_time(session, monkeypatch, tmp_path, draws):
    root = with_cache(session, monkeypatch, tmp_path)
    spec = make_spec(**BASE)
    monkeypatch.setattr(prepasses, "PREPASS_CACHE_MAX_BYTES", 0)
    first = session.render(spec)
    assert len(draws) == prepass_draws(spec) and entries(root) == []
    monkeypatch.undo()
    with_cache(session, monkeypatch, tmp_path)
    assert_same_render(first, session.render(spec))


def test_the_bench_draws_its_prepasses(session, monkeypatch, tmp_path, draws):
    """The bench times a frame as a moving chart draws it: its prepasses drawn, not read."""
    from sdfpbr.gpu.render import ChartDraw, chart_scene
    from sdfpbr.shading.plan import render_plan
    with_cache(session, monkeypatch, tmp_path)
    spec = make_spec(**BASE)
    session.render(spec)
    plan = render_plan(spec)
    draws.clear()
    with session:
        chart = ChartDraw(session, plan)
        scene = chart_scene(session, plan)
        try:
            prepasses.bind_frame(session, plan, scene, chart.programs, cached=False)
        finally:
            scene.release()
            chart.release()
    assert len(draws) == prepass_draws(spec)


def test_a_frame_bound_again_reads_the_prepasses_it_kept(session, monkeypatch, tmp_path, draws):
    """A scene's next frame is keyed without the last frame's prepasses (bind_frame forgets them):
    the same prepasses again, read from the cache, and no new entries."""
    from sdfpbr.gpu.render import ChartDraw, chart_scene
    from sdfpbr.shading.plan import render_plan
    root = with_cache(session, monkeypatch, tmp_path)
    spec = make_spec(**BASE)
    plan = render_plan(spec)
    with session:
        chart = ChartDraw(session, plan)
        scene = chart_scene(session, plan)
        try:
            n = prepass_draws(spec)
            prepasses.bind_frame(session, plan, scene, chart.programs)
            assert len(draws) == n and len(entries(root)) == n
            prepasses.bind_frame(session, plan, scene, chart.programs)
            assert len(draws) == n and len(entries(root)) == n
            assert len(scene.textures) == len({name for name, _ in scene.textures})
        finally:
            scene.release()
            chart.release()
