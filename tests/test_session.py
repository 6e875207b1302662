"""The explicit GL session and the program plan: what a render runs is decided once, a session
is handed to what renders, threads share a session behind its lock or use their own."""
import threading

import numpy as np
import pytest

import sdfpbr
from sdfpbr.cache import ArrayCache
from sdfpbr.gpu.gl import create_context
from sdfpbr.gpu.session import Session, default_session
from sdfpbr.shading.compose import OptionSchema, compose
from sdfpbr.shading.plan import SCHEMA, reference_plan, render_plan
from sdfpbr.spec.chart_spec import make_spec

SMALL = dict(width=48, height=40, rows=2, cols=3)


def test_chart_can_be_called_again_after_its_first_call():
    """`import sdfpbr; sdfpbr.chart(); sdfpbr.chart()`: no submodule replaces the function."""
    a = sdfpbr.chart(**SMALL)
    b = sdfpbr.chart(**SMALL)
    assert callable(sdfpbr.chart)
    np.testing.assert_array_equal(a.image, b.image)


def test_the_plan_names_every_program_a_render_compiles(cache_dir):
    """Render on a fresh session with a fresh cache: the programs it compiled are exactly the
    plan's (the cache copies are compiled when bakes go to or come from disk)."""
    spec = make_spec(**SMALL, env="sky", quality="draft")
    session = Session(create_context("egl"), ArrayCache(cache_dir / "plan-test"))
    try:
        session.render(spec)
        compiled = set(session.programs.digests())
        planned = {s.digest for s in render_plan(spec).sources()}
        assert compiled <= planned
        plan = render_plan(spec)
        # The vertex stage is linked into every fragment program, not compiled alone; a fresh
        # bake copies levels to the disk cache but never back; the probe's turn runs only in
        # a light orbit (Session.turning_light); and the chart is drawn by the fragment program
        # and its edge pass, or by the compute program (Session.chart_shader).
        unused = ({plan.chart_compute} if session.chart_shader == "fragment"
                  else {plan.chart, plan.edge_pass, plan.sphere_pass, plan.instances_vertex} - {None})
        assert planned - compiled == {plan.vertex.digest, plan.ibl.copy_to_cube.digest, plan.ibl.turn_probe.digest,
                                      *(s.digest for s in unused)}
    finally:
        session.release()


def test_features_a_spec_leaves_out_leave_programs_out():
    plan = render_plan(make_spec(ibl=False))
    assert plan.ibl is None
    assert "prefilter_main.glsl" not in {m for s in plan.sources() for m in s.modules}
    assert render_plan(make_spec(bugs=["fewtap-ibl"])).ibl is None
    assert render_plan(make_spec()).ibl is not None


def test_a_program_is_the_same_text_whatever_the_options_it_never_reads():
    """An option a program neither tests nor names leaves its text (so its compile and its
    bakes' cache keys) alone: the stage probe shades the floor, which has no normal or ORM map,
    so a bug in reading those maps leaves the probe as it is (it was a bake of its own per
    bug). An option it reads stays in its header."""
    from sdfpbr.features.compare import bug_pair
    for name in ("normal-map-srgb", "orm-srgb"):
        bug, correct, buggy = bug_pair(make_spec(), name)
        plan, buggy_plan = render_plan(correct), render_plan(buggy)
        assert dict(buggy_plan.ibl.stage_probe.options)[bug.option]
        assert not dict(plan.ibl.stage_probe.options).get(bug.option)
        assert buggy_plan.ibl.stage_probe.text == plan.ibl.stage_probe.text
        assert buggy_plan.chart.text != plan.chart.text
        assert f"#define {bug.option} 1" in buggy_plan.chart.text
    plain = render_plan(make_spec())
    brdf_bug = render_plan(make_spec(bugs=["unsquared-roughness"]))
    assert "#define BUG_UNSQUARED_ROUGHNESS 1" in brdf_bug.chart.text
    assert brdf_bug.ibl.stage_probe.text != plain.ibl.stage_probe.text   # the floor is shaded with it


def test_bugs_and_presets_are_resolved_by_the_plan_not_the_composer():
    """The composer evaluates whatever schema it is given: a bug switch is legal only because
    the plan's schema names it."""
    assert {"BUG_UNSQUARED_ROUGHNESS", "CLEARCOAT", "SHEEN", "KHR_SPECULAR", "EMISSION"} <= set(SCHEMA.switches)
    with pytest.raises(ValueError, match="KHR_SPECULAR|BUG_UNSQUARED_ROUGHNESS"):
        compose("brdf.glsl", {"BRDF_MODEL": "gltf", "MULTISCATTER": True},
                OptionSchema(choices={"BRDF_MODEL": ("gltf", "schlick_ggx")}, flags=("MULTISCATTER",)))
    seed = render_plan(make_spec(quality="seed002"))
    assert dict(seed.chart.options)["BRDF_MODEL"] == "schlick_ggx"
    assert dict(seed.chart.options)["BUG_FEWTAP_IBL"] and dict(seed.display.options)["BUG_DOUBLE_TONEMAP"]


def test_the_reference_plan_renders_the_scene_without_bugs_or_preset():
    plan = reference_plan(make_spec(bugs=["metal-diffuse"], quality="seed002"))
    assert plan.scene.bugs == () and plan.scene.quality == "default"
    assert not any(k.startswith("BUG_") for k in plan.options)


def _render_in_threads(make_session, count: int) -> list:
    spec = make_spec(**SMALL)
    images, errors = [None] * count, []

    def work(i):
        try:
            images[i] = sdfpbr.chart(spec, session=make_session()).image
        except Exception as exc:   # collected: the assertion below names it
            errors.append(repr(exc))

    threads = [threading.Thread(target=work, args=(i,)) for i in range(count)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    return images


def test_four_threads_share_the_default_session():
    images = _render_in_threads(lambda: default_session(), 4)
    for image in images[1:]:
        np.testing.assert_array_equal(images[0], image)


def test_threads_may_each_use_their_own_session(cache_dir):
    sessions = []
    lock = threading.Lock()

    def own():
        s = Session(create_context("egl"), ArrayCache(cache_dir))
        with lock:
            sessions.append(s)
        return s

    try:
        images = _render_in_threads(own, 2)
    finally:
        for s in sessions:
            s.release()
    np.testing.assert_array_equal(images[0], images[1])
    np.testing.assert_array_equal(images[0], sdfpbr.chart(**SMALL).image)


def test_a_session_can_be_entered_again_by_the_thread_that_holds_it(session):
    with session:
        with session:
            pass
        assert session.ctx.info["GL_RENDERER"]   # still current after the inner exit ("" if not)
        result = session.render(make_spec(**SMALL))
    assert result.image.shape == (40, 48, 4)
