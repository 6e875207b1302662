"""The cells stage's plates kept in the disk cache (gpu/plates.py): a chart drawn again reads
them instead of drawing them, and gets the same pixels; anything a plate is drawn with that
changes is a plate drawn anew; what has no key is drawn every time."""
import numpy as np
import pytest

from sdfpbr.cache import ArrayCache
from sdfpbr.gpu import plates
from sdfpbr.spec.chart_spec import Light, make_spec

BASE = dict(size="360x320", rows=4, cols=3, labels=False)   # all three plates (slots shared by 4 rows)


@pytest.fixture
def draws(monkeypatch):
    """The plates drawn (not read from the cache), by their program's name, as they happen."""
    drawn = []
    draw = plates._draw_plate

    def counting(session, source, *args, **kwargs):
        drawn.append(next(m for m in source.modules if m.endswith("_main.glsl")))
        return draw(session, source, *args, **kwargs)
    monkeypatch.setattr(plates, "_draw_plate", counting)
    return drawn


def with_cache(session, monkeypatch, root):
    """Plates go to (and come from) a cache of their own; the IBL bakes stay where they are."""
    monkeypatch.setattr(session, "cache", ArrayCache(root))
    return root


def plate_draws(spec) -> int:
    """The plates a frame of ``spec`` draws: floor, bounce, gather and sphere plates where its
    plan has them, and one per draw of the bounce cache."""
    from sdfpbr.shading.plan import render_plan
    plan = render_plan(spec)
    return (sum(s is not None for s in (plan.floor_plate, plan.bounce_plate, plan.gather_plate, plan.sphere_plate))
            + plan.bounce_iterations)


def entries(root):
    return (sorted(p.name for p in (root / plates.PLATE_KIND).glob("*.npz"))
            if (root / plates.PLATE_KIND).is_dir() else [])


def assert_same_render(a, b):
    np.testing.assert_array_equal(a.hdr, b.hdr)
    np.testing.assert_array_equal(a.alpha, b.alpha)
    np.testing.assert_array_equal(a.image, b.image)
    for name in a.aov:
        np.testing.assert_array_equal(a.aov[name], b.aov[name])


def test_a_chart_drawn_again_reads_its_plates(session, monkeypatch, tmp_path, draws):
    root = with_cache(session, monkeypatch, tmp_path)
    spec = make_spec(**BASE)
    first = session.render(spec)
    n = plate_draws(spec)
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
    dict(quality="high"),
    dict(bugs=("unsquared-roughness",)),                                 # another program
    dict(env="sky"),
    dict(transparent=True),                                              # the floor a shadow catcher
    dict(spp=4),
])
def test_a_changed_chart_draws_what_changed(session, monkeypatch, tmp_path, draws, change):
    """With the first chart's plates in the cache, a chart that differs in one field renders
    exactly as it does from an empty cache: no plate it reads was made for the other chart."""
    with_cache(session, monkeypatch, tmp_path / "warm")
    session.render(make_spec(**BASE))
    spec = make_spec(**{**BASE, **change})
    draws.clear()
    warm = session.render(spec)
    assert draws, "every change here reaches a plate"
    with_cache(session, monkeypatch, tmp_path / "empty")
    assert_same_render(warm, session.render(spec))


def test_plates_drawn_with_unkeyed_textures_are_not_kept(session, monkeypatch, tmp_path, draws):
    """Surface maps carry no content key: their chart's plates are drawn every time."""
    root = with_cache(session, monkeypatch, tmp_path)
    spec = make_spec(**BASE, textures="procedural")
    session.render(spec)
    assert draws and entries(root) == []


def test_a_uniform_the_scene_does_not_set_keeps_the_plate_out(session, monkeypatch, tmp_path, draws):
    """A plate program that reads a uniform missing from the scene's (its value is whatever an
    earlier draw left on the program) is drawn but not kept."""
    from sdfpbr.gpu import frame
    root = with_cache(session, monkeypatch, tmp_path)
    chart_uniforms = frame.chart_uniforms

    def without_ground(*args):
        values = dict(chart_uniforms(*args))
        values.pop("u_ground_color")          # read by the floor plate
        return values
    monkeypatch.setattr(frame, "chart_uniforms", without_ground)
    session.render(make_spec(**BASE))
    assert len(draws) == plate_draws(make_spec(**BASE)) and draws[0].endswith("floor_main.glsl")
    assert entries(root) == []   # nor the plates after it: their keys would hold its key


def test_plates_over_the_size_cap_are_drawn_every_time(session, monkeypatch, tmp_path, draws):
    root = with_cache(session, monkeypatch, tmp_path)
    spec = make_spec(**BASE)
    monkeypatch.setattr(plates, "PLATE_CACHE_MAX_BYTES", 0)
    first = session.render(spec)
    assert len(draws) == plate_draws(spec) and entries(root) == []
    monkeypatch.undo()
    with_cache(session, monkeypatch, tmp_path)
    assert_same_render(first, session.render(spec))


def test_the_bench_draws_its_plates(session, monkeypatch, tmp_path, draws):
    """The bench times a frame as a moving chart draws it: its plates drawn, not read."""
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
            plates.bind_frame(session, plan, scene, chart.programs, cached=False)
        finally:
            scene.release()
            chart.release()
    assert len(draws) == plate_draws(spec)


def test_a_frame_bound_again_reads_the_plates_it_kept(session, monkeypatch, tmp_path, draws):
    """A scene's next frame is keyed without the last frame's plates (bind_frame forgets them):
    the same plates again, read from the cache, and no new entries."""
    from sdfpbr.gpu.render import ChartDraw, chart_scene
    from sdfpbr.shading.plan import render_plan
    root = with_cache(session, monkeypatch, tmp_path)
    spec = make_spec(**BASE)
    plan = render_plan(spec)
    with session:
        chart = ChartDraw(session, plan)
        scene = chart_scene(session, plan)
        try:
            n = plate_draws(spec)
            plates.bind_frame(session, plan, scene, chart.programs)
            assert len(draws) == n and len(entries(root)) == n
            plates.bind_frame(session, plan, scene, chart.programs)
            assert len(draws) == n and len(entries(root)) == n
            assert len(scene.textures) == len({name for name, _ in scene.textures})
        finally:
            scene.release()
            chart.release()
