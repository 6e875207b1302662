"""The bug catalog: each bug is exactly one compile option away from the correct chart, and
changes the image where the physics says it should (FLIP per sphere cell)."""
import math

import numpy as np
import pytest

from sdfpbr.image import metrics
from sdfpbr.spec.bugs import BUGS, get_bug
from sdfpbr.cli.main import main
from sdfpbr.errors import SpecError
from sdfpbr.shading.plan import chart_options, render_plan
from sdfpbr.spec.chart_spec import ChartSpec, make_spec

from helpers import PROGRAM_RTOL

# The shared stage: its spheres see the environment, not a floor whose BRDF a bug also changes,
# so a bug's effect on the spheres is its effect on their BRDF alone.
BASE = ChartSpec(width=96, height=96, labels=False, stage="shared")


def _options(spec):
    return {"chart": chart_options(spec), "display": dict(render_plan(spec).display.options)}


# Options a bug turns off by what it removes: the few-tap path has no prefiltered environment,
# from which the ground's IBL table and the stage probe are baked and which the shared stage's
# neighbours' light reads.
IMPLIED_OPTIONS = {"fewtap-ibl": {"GROUND_IBL", "STAGE_PROBE", "NEIGHBOUR_LIGHT"}}


@pytest.mark.parametrize("name", list(BUGS))
def test_bug_changes_exactly_its_own_option(name):
    bug = BUGS[name]
    correct = bug.correct(BASE)
    buggy = bug.apply(BASE)
    before, after = _options(correct), _options(buggy)
    other = "display" if bug.program == "chart" else "chart"
    assert before[other] == after[other]
    changed = {k for k in set(before[bug.program]) | set(after[bug.program])
               if before[bug.program].get(k) != after[bug.program].get(k)}
    assert changed == {bug.option} | IMPLIED_OPTIONS.get(name, set())
    assert after[bug.program][bug.option] == bug.value
    # The option does something: the composed program text differs beyond its header line.
    src_a = (render_plan(correct).chart if bug.program == "chart" else render_plan(correct).display).text
    src_b = (render_plan(buggy).chart if bug.program == "chart" else render_plan(buggy).display).text
    def body(t):
        return "\n".join(l for l in t.splitlines() if not l.startswith(("#define", "// option")))
    assert body(src_a) != body(src_b)


def _cell_flip(session, correct, buggy):
    a, b = session.render(correct), session.render(buggy)
    _, error_map = metrics.flip_ldr(b.image, a.image)
    cells = metrics.per_cell_mean(error_map, a.aov["row"], a.aov["col"], correct.rows, correct.cols)
    return cells


@pytest.mark.parametrize("name", list(BUGS))
def test_bug_changes_the_image(session, name):
    bug = BUGS[name]
    cells = _cell_flip(session, bug.correct(BASE), bug.apply(BASE))
    assert np.nanmax(cells) > 0.02, f"{name}: largest per-cell FLIP {np.nanmax(cells):.4f}"


def _flips(session, correct, buggy):
    a, b = session.render(correct), session.render(buggy)
    mean, error_map = metrics.flip_ldr(b.image, a.image)
    cells = metrics.per_cell_mean(error_map, a.aov["row"], a.aov["col"], correct.rows, correct.cols)
    return mean, float(np.nanmax(cells))


# Per scene, the FLIP of a change a person sees side by side (below): 22 bugs share 9 scenes.
_VISIBLE: dict = {}


def visible_flip(session, correct):
    """(mean, worst cell) FLIP of ``correct`` against itself 5 % brighter."""
    if correct not in _VISIBLE:
        _VISIBLE[correct] = _flips(session, correct, make_spec(correct, exposure=correct.exposure + math.log2(1.05)))
    return _VISIBLE[correct]


@pytest.mark.parametrize("name", list(BUGS))
def test_every_bug_is_visible_in_its_own_scene(session, name):
    """On the default chart at 256 px plus what the bug requires (its scene), the bug differs
    from the correct render at least as much as a change a person sees side by side in that
    same scene: 5 % brighter (2.5x Weber's 2 % just-noticeable luminance difference), over the
    image or on its most affected sphere."""
    bug = BUGS[name]
    spec = make_spec(width=256, height=256, labels=False)
    correct = bug.correct(spec)
    visible = visible_flip(session, correct)
    mean, cell = _flips(session, correct, bug.apply(spec))
    assert mean >= visible[0] or cell >= visible[1], (name, mean, cell, visible)


def _cell_hdr_change(session, correct, buggy, relative=False):
    a, b = session.render(correct), session.render(buggy)
    diff = np.abs(a.hdr - b.hdr).max(axis=-1)
    if relative:   # to the pixel's radiance (positive sums: no cancellation to lose it in)
        diff = diff / np.maximum(np.maximum(np.abs(a.hdr), np.abs(b.hdr)).max(axis=-1), np.finfo(np.float32).tiny)
    out = np.zeros((correct.rows, correct.cols))
    for r in range(correct.rows):
        for c in range(correct.cols):
            out[r, c] = diff[(a.aov["row"] == r) & (a.aov["col"] == c)].max()
    return out


def test_bugs_leave_unaffected_spheres_alone(session):
    # Radiance, not FLIP: FLIP's spatial filter spreads a neighbour's error into a cell. On the
    # cells stage, where a sphere sees no other (on the shared one it reflects its neighbours,
    # whose light a bug changes too).
    cells = make_spec(BASE, stage="cells")
    # A metal has no diffuse body: the bug touches metallic rows, not the dielectric row 0.
    change = _cell_hdr_change(session, cells, BUGS["metal-diffuse"].apply(cells))
    rel = _cell_hdr_change(session, cells, BUGS["metal-diffuse"].apply(cells), relative=True)
    assert rel[0].max() <= PROGRAM_RTOL and change[-1].min() > 0.05
    # alpha = r and alpha = r^2 agree at r = 1 (the last column) and nowhere else. With no floor:
    # the bug also roughens the floor (r = 0.8), which every sphere sees in its reflections.
    sky = make_spec(BASE, ground=False, ao=False)
    change = _cell_hdr_change(session, sky, BUGS["unsquared-roughness"].apply(sky))
    rel = _cell_hdr_change(session, sky, BUGS["unsquared-roughness"].apply(sky), relative=True)
    assert rel[:, -1].max() <= PROGRAM_RTOL and change[:, :-1].min() > 0.01
    # AO on direct light: only where a neighbour occludes, never on an isolated sphere (with no
    # floor: the bug darkens the floor's sun by the sphere's occlusion, and the sphere sees it).
    lone = make_spec(BASE, rows=1, cols=1, ground=False)
    bug = BUGS["ao-on-direct"]
    change = _cell_hdr_change(session, bug.correct(lone), bug.apply(lone))
    assert change.max() < 1e-5   # ao = 1: only float rounding of (c - ibl) * 1 + ibl
    # N.V unclamped: with no normal map every shaded point faces its viewer (N.V > 0), where
    # the textbook division equals the visibility form: nothing but rounding may change.
    unclamped = make_spec(BASE, bugs=("unclamped-ndotv",))
    assert unclamped.textures == "none"
    assert _cell_hdr_change(session, BASE, unclamped, relative=True).max() <= PROGRAM_RTOL


def test_unknown_bug_is_one_line():
    with pytest.raises(SpecError, match="unknown bug 'unsquared'.*did you mean 'unsquared-roughness'"):
        get_bug("unsquared")
    with pytest.raises(SpecError):
        make_spec(BASE, bugs=("nope",))


def test_bugs_command_lists_every_bug(capsys):
    assert main(["bugs"]) == 0
    out = capsys.readouterr().out
    assert all(name in out for name in BUGS)


def test_seed002_preset_composes_the_seeds_approach():
    spec = make_spec(BASE, quality="seed002")
    src = render_plan(spec).chart
    opts = dict(src.options)
    assert opts["SCENE_SDF"] == "all_spheres" and opts["INTERSECT"] == "march"
    assert opts["NORMAL_METHOD"] == "central" and opts["BRDF_MODEL"] == "schlick_ggx"
    assert opts["BUG_FEWTAP_IBL"] and opts["BUG_IBL_DIRECT_K"]
    assert "ibl_fewtap.glsl" in src.modules and "ibl.glsl" not in src.modules
    assert dict(render_plan(spec).display.options)["BUG_DOUBLE_TONEMAP"]


def test_seed002_renders_close_to_default(session):
    # Different approximations of the same scene: same silhouettes, different shading.
    a = session.render(BASE)
    b = session.render(make_spec(BASE, quality="seed002"))
    same = (a.aov["row"] >= 0) == (b.aov["row"] >= 0)
    assert same.mean() > 0.97
    assert np.isfinite(b.hdr).all()
