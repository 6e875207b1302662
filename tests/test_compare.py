"""Comparison sheets: panels pasted pixel-exactly where the sheet says, FLIP differences that
vanish for identical specs and sit where the specs differ, per-sphere numbers that are the
per-cell means of the map, sweeps and contact sheets, and the compare / sweep commands."""
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from sdfpbr.spec.fields import sweep_values_from_text
from PIL import Image

from sdfpbr.spec.bugs import BUGS
from sdfpbr.shading.camera import sphere_centers
from sdfpbr.api import chart
from sdfpbr.features.compare import (BUGS_PER_PAGE, bug_catalog, bug_contact_sheet, bug_pair, catalog_pages,
                                     compare_bug, compare_specs, sweep)
from sdfpbr.image.sheet import flatten
from sdfpbr.errors import SpecError
from sdfpbr.image.metrics import DEFAULT_PPD, apply_colormap, flip_ldr, per_cell_mean
from sdfpbr.spec.chart_spec import make_spec

SMALL = dict(width=96, height=96, quality="draft", stage="shared")   # sphere positions by the grid camera


def display(spec):
    """The unlabeled display image of a spec, rendered independently of the sheet."""
    return flatten(chart(spec).result.image)


# How far FLIP's widest spatial filter reaches: ceil(3 sqrt(b / (2 pi^2)) ppd) pixels for the
# blue-yellow channel's b = 0.04 deg^2 (Andersson et al. 2020): 10 at the default ppd.
FLIP_REACH_PX = math.ceil(3 * math.sqrt(0.04 / (2 * math.pi ** 2)) * DEFAULT_PPD)


def background_far_from_spheres(spec, margin_px):
    """Pixels farther than ``margin_px`` from every projected sphere (closed form)."""
    res = chart(spec).result
    px, scale = res.camera.project(sphere_centers(spec).reshape(-1, 3))
    yy, xx = np.mgrid[:spec.height, :spec.width] + 0.5
    dist = np.min([np.hypot(xx - x, yy - y) - spec.sphere_radius * k for (x, y), k in zip(px, scale)], axis=0)
    return dist > margin_px


def test_identical_specs_give_a_zero_difference_and_exact_panels():
    spec = make_spec(**SMALL)
    sheet = compare_specs(spec, spec, labels=("left", "right"))
    a, b, diff = sheet.panels
    d = sheet.differences[0]
    assert d.mean == 0.0 and not d.error_map.any()
    assert np.nanmax(d.per_cell) == 0.0
    # Renders pasted unresampled at the boxes the sheet reports, left to right, tops aligned.
    want = display(spec)
    for p in (a, b):
        assert (p.box.w, p.box.h) == (spec.width, spec.height)
        np.testing.assert_array_equal(p.box.crop(sheet.image)[..., :3], want[..., :3])
    assert a.box.y == b.box.y == diff.box.y
    assert a.box.x + a.box.w < b.box.x and b.box.x + b.box.w < diff.box.x
    assert diff.box.x + diff.box.w < sheet.image.shape[1] and a.box.y + a.box.h < sheet.image.shape[0]
    # The difference panel is the colour-mapped map, apart from the printed numbers.
    heat = apply_colormap(d.error_map)
    unprinted = np.ones(heat.shape[:2], bool)
    for c in d.cells:
        x, y = int(c.x) - diff.box.x, int(c.y) - diff.box.y
        unprinted[max(0, y - 12):y + 12, max(0, x - 24):x + 24] = False
    np.testing.assert_array_equal(diff.box.crop(sheet.image)[..., :3][unprinted], heat[unprinted])
    assert sheet.image.shape[2] == 4 and sheet.image.dtype == np.uint8
    assert "same spec" in sheet.caption


def test_exposure_difference_is_large_on_spheres_and_nil_far_from_them():
    """+3 EV over a black, groundless scene: every lit sphere changes a lot, the black
    background (identical in both) does not, beyond the reach of FLIP's filters."""
    spec = make_spec(**SMALL, env="black", ground=False, rows=3, cols=3)
    brighter = make_spec(spec, exposure=3.0)
    sheet = compare_specs(spec, brighter)
    d = sheet.differences[0]
    res = chart(spec)
    interior = (res.aov["row"] >= 0) & (res.aov["ndotv"] > 0.3)
    assert d.error_map[interior].mean() > 0.4
    far = background_far_from_spheres(spec, FLIP_REACH_PX)
    assert far.sum() > 20 and d.error_map[far].max() < 0.02
    assert "exposure 0 -> 3" in sheet.caption
    assert d.mean == pytest.approx(flip_ldr(display(brighter), display(spec))[0], abs=1e-6)


def test_numbers_on_the_spheres_are_the_per_cell_means_of_the_map():
    spec = make_spec(**{**SMALL, "width": 160, "height": 160})
    test = make_spec(spec, tonemap="clamp")
    sheet = compare_specs(spec, test)
    d = sheet.differences[0]
    # Independently: render both, FLIP them, average per sphere.
    mean, error_map = flip_ldr(display(test), display(spec))
    aov = chart(spec).aov
    want = per_cell_mean(error_map, aov["row"], aov["col"], spec.rows, spec.cols)
    np.testing.assert_allclose(d.per_cell, want, rtol=1e-6, atol=1e-7)
    printed = {(c.row, c.col): c for c in d.cells}
    assert len(printed) == np.isfinite(want).sum() == spec.rows * spec.cols
    for (r, c), cell in printed.items():
        decimals = len(cell.text.split(".")[1])
        assert abs(float(cell.text) - want[r, c]) <= 0.5 * 10 ** -decimals + 1e-9
        # ... and drawn there in white: no colour of the magma map has blue above 191 (its top
        # is 254,253,191), and the strokes reach 245+ in every channel in either font (DejaVu,
        # or Pillow's own where DejaVu is not installed).
        x, y = int(cell.x), int(cell.y)
        patch = sheet.image[y - 6:y + 6, x - 12:x + 12, :3]
        assert (patch.min(axis=-1) > 200).any()


def test_bug_comparison_is_captioned_and_differs_where_alpha_changes():
    """unsquared-roughness uses r instead of r^2: identical at r = 1, different in between.
    With nothing else in the spheres' reflections: no floor (the bug roughens it too) and no
    occlusion, so no neighbours' light (the r = 0.75 spheres, which the bug changes)."""
    spec = make_spec(**{**SMALL, "width": 128, "height": 128, "ground": False, "ao": False})
    sheet = compare_bug(spec, "unsquared-roughness")
    bug = BUGS["unsquared-roughness"]
    assert bug.name in sheet.title and bug.summary in sheet.title and bug.caption in sheet.caption
    correct, buggy = sheet.specs
    assert "unsquared-roughness" in buggy.bugs and "unsquared-roughness" not in correct.bugs
    per_cell = sheet.differences[0].per_cell
    assert per_cell[:, -1].max() < 0.01                 # r = 1: alpha = r = r^2
    assert per_cell[1:, 1:-1].max() > 0.1               # mid roughness: alpha 0.25..0.75 vs 0.06..0.56
    # r = 0 differs too (the clamp's 0.045 is taken as alpha), as the caption says, on the metal row
    assert per_cell[-1, 0] > 3 * per_cell[-1, -1] and "Only r = 1 agrees" in bug.caption
    # The buggy panel's axis says what the bug does with r; the correct one keeps alpha = r^2.
    from sdfpbr.image.chart_labels import axis_title
    assert "α = r," in axis_title(buggy, "x") and "α = r²" in axis_title(correct, "x")
    assert [p.label for p in sheet.panels][:2] == ["correct", "buggy: unsquared-roughness"]
    # The correct panel is the plain chart; the buggy one the chart with the bug on.
    np.testing.assert_array_equal(sheet.panels[0].box.crop(sheet.image)[..., :3], display(correct)[..., :3])
    np.testing.assert_array_equal(sheet.panels[1].box.crop(sheet.image)[..., :3],
                                  display(make_spec(spec, bugs=("unsquared-roughness",)))[..., :3])


def test_bug_pair_for_a_spec_that_already_has_the_bug():
    spec = make_spec(**SMALL, bugs=("clamp-tonemap",))
    _, correct, buggy = bug_pair(spec, "clamp-tonemap")
    assert correct.bugs == () and buggy.bugs == ("clamp-tonemap",)


def test_sheet_saves_png_with_specs_and_digests(tmp_path):
    spec = make_spec(**SMALL)
    sheet = compare_bug(spec, "clamp-tonemap")
    out = tmp_path / "cmp.png"
    sheet.save(out)
    with Image.open(out) as im:
        assert im.size == (sheet.image.shape[1], sheet.image.shape[0])
        text = im.text
        np.testing.assert_array_equal(np.asarray(im.convert("RGBA")), sheet.image)
    for i, s in enumerate(sheet.specs):
        assert json.loads(text[f"sdfpbr:spec:{i}"]) == json.loads(json.dumps(s.to_dict()))
    # A display-program bug: the chart program is the same, the display program is not.
    assert text["sdfpbr:shader-sha256:0"] == text["sdfpbr:shader-sha256:1"]
    assert text["sdfpbr:display-shader-sha256:0"] != text["sdfpbr:display-shader-sha256:1"]
    assert text["Description"] == sheet.caption
    with pytest.raises(SpecError, match=r"\.png"):
        sheet.save(tmp_path / "cmp.jpg")
    assert not (tmp_path / "cmp.jpg").exists()


def test_contact_sheet_is_a_row_per_bug_quoting_the_figures_compare_quotes():
    spec = make_spec(**SMALL)
    names = ["clamp-tonemap", "double-gamma", "no-cosine"]
    sheet = bug_contact_sheet(spec, names, panel_size=64, measure_size=None)
    assert len(sheet.panels) == 9 and len(sheet.differences) == 3
    assert len(sheet.specs) == 4                        # the correct chart is rendered once
    rows = [sheet.panels[i:i + 3] for i in (0, 3, 6)]
    for row in rows:
        assert [p.box.w for p in row] == [64, 64, 64] and len({p.box.y for p in row}) == 1
        assert [p.label for p in row[:2]] == ["correct", "buggy"]
        assert row[0].box.x < row[1].box.x < row[2].box.x                       # side by side
        assert sheet.specs[row[0].spec_index] == bug_pair(spec, "clamp-tonemap")[1]
    for upper, lower in zip(rows, rows[1:]):
        assert lower[0].box.y >= upper[0].box.y + 64 and lower[0].box.x == upper[0].box.x   # a row each
    for d, name in zip(sheet.differences, names):
        assert d.mean > 0.1
        # One figure per bug: the sheet measures what `compare --bug` measures at the same size.
        assert d.mean == compare_bug(spec, name).differences[0].mean
    with pytest.raises(SpecError, match="allowed: unsquared-roughness"):
        bug_contact_sheet(spec, ["clamp-tonemap", "no-such-bug"])


@pytest.mark.parametrize("count, per_page, sizes", [
    (22, 8, [8, 7, 7]), (16, 8, [8, 8]), (17, 8, [6, 6, 5]), (5, 8, [5]), (1, 1, [1]), (3, 1, [1, 1, 1])])
def test_catalog_pages_are_as_even_as_they_can_be(count, per_page, sizes):
    names = [f"b{i}" for i in range(count)]
    pages = catalog_pages(names, per_page)
    assert [len(p) for p in pages] == sizes and [n for p in pages for n in p] == names
    with pytest.raises(SpecError, match="positive whole number"):
        catalog_pages(names, 0)


def test_the_catalog_is_pages_that_each_fit_a_page():
    """Every bug on one sheet was 2244 x 5900 px in 14-px text: now pages of BUGS_PER_PAGE rows,
    each narrower than a wide screen and no taller than about an A4 page is for its width."""
    spec = make_spec(**SMALL)
    names = ["clamp-tonemap", "double-gamma", "gamma-2.2"]
    pages = bug_catalog(spec, names, per_page=2, measure_size=None)
    assert [len(p.differences) for p in pages] == [2, 1]
    assert [p.title for p in pages] == ["PBR bug catalog: 3 bugs, page 1 of 2", "PBR bug catalog: 3 bugs, page 2 of 2"]
    assert pages[1].differences[0].mean == compare_bug(spec, "gamma-2.2").differences[0].mean
    (alone,) = bug_catalog(spec, names, per_page=2, measure_size=None, pages=[2])
    np.testing.assert_array_equal(alone.image, pages[1].image)
    with pytest.raises(SpecError, match="numbered 1 to 2"):
        bug_catalog(spec, names, per_page=2, pages=[3])
    full = bug_catalog(spec, list(BUGS)[:BUGS_PER_PAGE], measure_size=None)   # a full page at the defaults
    (h, w), = {p.image.shape[:2] for p in full}
    assert len(full) == 1 and w <= 1200 and h <= 1.7 * w


@pytest.mark.parametrize("make", ["sweep", "bug", "catalog"])
def test_sheets_lie_on_the_charts_backdrop(make):
    """Charts laid onto a light page made a light render in a dark frame: the sheet is on the
    backdrop too, its text dark enough to read on it (WCAG contrast, as a chart's labels)."""
    from sdfpbr.image.layout import page_colour, text_colour
    backdrop = (0.96, 0.95, 0.92)
    spec = make_spec(**SMALL, backdrop=backdrop)
    sheet = {"sweep": lambda: sweep(spec, "tonemap", ["aces", "clamp"]),
             "bug": lambda: compare_bug(spec, "no-cosine"),
             "catalog": lambda: bug_contact_sheet(spec, ["no-cosine"], panel_size=64, measure_size=None)}[make]()
    page = np.array(page_colour(backdrop)[:3])
    corners = sheet.image[[0, 0, -1, -1], [0, -1, 0, -1], :3]
    assert (corners == page).all()
    ink = np.array(text_colour("title", backdrop)[:3])
    assert ink.max() < page.min()                          # dark text on the light page
    assert (np.abs(sheet.image[..., :3].astype(int) - ink).max(axis=-1) == 0).any()   # and drawn in it


def test_contact_sheet_shows_small_panels_of_bigger_measured_renders():
    """Panels shown at 64 px, figures measured at 128 px: the numbers are the bigger render's."""
    spec = make_spec(**{**SMALL, "width": 128, "height": 128})
    sheet = bug_contact_sheet(spec, ["metal-diffuse"], panel_size=64, measure_size=128)
    (d,) = sheet.differences
    assert d.error_map.shape == (128, 128) and sheet.panels[0].box.w == 64
    assert d.mean == compare_bug(spec, "metal-diffuse").differences[0].mean
    assert "measured at 128x128" in sheet.caption


def test_sweep_has_one_labeled_panel_per_value():
    spec = make_spec(**SMALL)
    values = ["aces", "clamp", "reinhard"]
    sheet = sweep(spec, "tonemap", values)
    assert [p.label for p in sheet.panels] == [f"tonemap {v}" for v in values]
    assert [s.tonemap for s in sheet.specs] == values
    crops = [p.box.crop(sheet.image)[..., :3] for p in sheet.panels]
    for crop, value in zip(crops, values):
        np.testing.assert_array_equal(crop, display(make_spec(spec, tonemap=value))[..., :3])
    for i in range(3):
        for j in range(i + 1, 3):
            assert np.abs(crops[i].astype(int) - crops[j].astype(int)).mean() > 1.0
    # Each panel's label is drawn in the band above its render.
    for p in sheet.panels:
        band = sheet.image[max(0, p.box.y - 40):p.box.y, p.box.x:p.box.x + p.box.w, :3]
        assert (band.max(axis=-1) > 200).any()


def test_sweep_grid_and_values():
    spec = make_spec(**{**SMALL, "width": 48, "height": 48})
    sheet = sweep(spec, "exposure", [-2, -1, 0, 1, 2], columns=2)
    ys = sorted({p.box.y for p in sheet.panels})
    assert len(ys) == 3 and [p.label for p in sheet.panels][0] == "exposure -2 EV"
    assert sweep_values_from_text("exposure", "-2,0,2.5") == [-2.0, 0.0, 2.5]
    assert sweep_values_from_text("multiscatter", "on,off") == [True, False]
    assert sweep_values_from_text("roughness", "0:0.5;0.5:1") == [(0.0, 0.5), (0.5, 1.0)]
    with pytest.raises(SpecError, match="did you mean 'tonemap'"):
        sweep(spec, "tonemapp", ["aces"])
    with pytest.raises(SpecError, match="allowed"):
        sweep(spec, "tonemap", ["aces", "filmic"])


def test_specs_of_different_sizes_are_refused():
    with pytest.raises(SpecError, match="same size"):
        compare_specs(make_spec(**SMALL), make_spec(**{**SMALL, "width": 64}))


# ---------------------------------------------------------------------------------------------
# Command line.

def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "sdfpbr", *args], capture_output=True, text=True, cwd=cwd)


@pytest.mark.parametrize("args, needle", [
    (["compare", "--bug", "unsquared-rougness"], "did you mean 'unsquared-roughness'"),
    (["compare", "--bugs", "clamp-tonemap,nope"], "allowed: unsquared-roughness"),
    (["compare", "missing-a.toml", "missing-b.toml"], "does not exist"),
    (["compare", "one.toml"], "two spec files"),
    (["compare"], "nothing to compare"),
    (["compare", "--bug", "clamp-tonemap", "--bugs", "all"], "only one of"),
    (["compare", "--bugs", "all", "--frames", "3"], "--bug comparison only"),
    (["compare", "--bugs", "all", "--per-page", "-1"], "--per-page"),
    (["compare", "--bug", "clamp-tonemap", "--size", "big"], "WxH"),
    (["sweep", "tonemap", "--values", "aces,filmic"], "allowed"),
    (["sweep", "exposur"], "did you mean 'exposure'"),
    (["sweep", "exposure", "--values", "1,x"], "must be numbers"),
    (["sweep", "width"], "needs values"),
])
def test_bad_input_is_one_line_exit_2_no_file(tmp_path, args, needle):
    out = tmp_path / "out.png"
    out.write_bytes(b"keep me")
    r = run(*args, "-o", str(out))
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and needle in r.stderr and "Traceback" not in r.stderr
    assert out.read_bytes() == b"keep me"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]


@pytest.mark.parametrize("args", [["compare", "--bug", "clamp-tonemap"], ["sweep", "tonemap"]])
def test_bad_output_suffix_is_refused(tmp_path, args):
    r = run(*args, "--size", "48x48", "-o", str(tmp_path / "x.jpg"))
    assert r.returncode == 2 and "must end in .png" in r.stderr
    assert not list(tmp_path.iterdir())


def test_compare_and_sweep_commands_write_sheets(tmp_path):
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    a.write_text('size = "64x64"\nquality = "draft"\n')
    b.write_text('size = "64x64"\nquality = "draft"\nexposure = 2.0\n')
    r = run("compare", str(a), str(b), "-o", str(tmp_path / "ab.png"), "-v")
    assert r.returncode == 0, r.stderr
    assert "b vs a: mean FLIP" in r.stdout and "row 4:" in r.stdout
    r = run("compare", "--bug", "double-gamma", "--size", "64x64", "--quality", "draft", "-v", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "compare-double-gamma.png").is_file()
    r = run("sweep", "exposure", "--values", "-2,0,2", "--size", "48x48", "--quality", "draft",
            "-o", str(tmp_path / "sweep.png"))
    assert r.returncode == 0, r.stderr
    with Image.open(tmp_path / "sweep.png") as im:
        assert json.loads(im.text["sdfpbr:panels"]) == ["exposure -2 EV", "exposure +0 EV", "exposure +2 EV"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.toml", "ab.png", "b.toml",
                                                        "compare-double-gamma.png", "sweep.png"]


def test_a_catalog_longer_than_a_page_writes_numbered_pages_and_says_so(tmp_path):
    names = "clamp-tonemap,double-gamma,gamma-2.2"
    r = run("compare", "--bugs", names, "--per-page", "2", "--size", "48x48", "--quality", "draft",
            "-o", str(tmp_path / "cat.png"))
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cat-1.png", "cat-2.png"]
    assert r.stderr.splitlines()[-1] == f"sdfpbr: note: 2 pages: {tmp_path / 'cat-1.png'}, {tmp_path / 'cat-2.png'}"
    with Image.open(tmp_path / "cat-2.png") as im:
        assert im.text["Title"] == "PBR bug catalog: 3 bugs, page 2 of 2"
    r = run("compare", "--bugs", names, "--per-page", "0", "--size", "48x48", "--quality", "draft",
            "-o", str(tmp_path / "one.png"))
    assert r.returncode == 0 and (tmp_path / "one.png").is_file() and "note" not in r.stderr


def test_sheets_keep_their_renders_read_only_and_frames_are_not_kept():
    """The sheets render a spec once per process (the catalog's correct chart, a gallery's
    per-bug pages): a kept render is the same object, its arrays read-only; a render with AOVs
    serves one without; an animation frame (keep=False) is rendered and not kept."""
    from sdfpbr.spec.chart_spec import make_spec
    from sdfpbr.features import compare
    spec = make_spec(width=48, height=48, quality="draft", rows=2, cols=2)
    compare._kept.clear()
    with_aov = compare.render_chart(spec, aovs=True, keep=True)
    assert compare.render_chart(spec, keep=True) is with_aov
    assert not with_aov.result.image.flags.writeable and not with_aov.result.aov["row"].flags.writeable
    frame = compare.render_chart(spec)
    assert frame is not with_aov and frame.result.image.flags.writeable and len(compare._kept) == 1
    np.testing.assert_array_equal(frame.result.image, with_aov.result.image)
    sheet = compare.compare_bug(spec, "unsquared-roughness")
    assert (spec, True) in compare._kept and sheet.image.shape[0] > 0


def test_display_bugs_are_their_correct_charts_radiance_through_their_own_display_pass(monkeypatch):
    """A kept correct chart keeps its radiance: a display bug's chart (and gamma-2.2's darker
    correct one, which differs in exposure) is drawn from it through its own display pass, not
    drawn again, and is the very image (and sphere AOVs) a render of its own gives."""
    from sdfpbr.gpu.session import Session, default_session
    from sdfpbr.spec.fields import same_radiance
    from sdfpbr.features import compare
    spec = make_spec(width=64, height=48, quality="draft", rows=2, cols=3)
    drawn = []
    real = Session.render
    monkeypatch.setattr(Session, "render", lambda self, s, *a, **k: drawn.append(s) or real(self, s, *a, **k))
    compare._kept.clear()
    compare._radiance.clear()
    display_bugs = [b.name for b in BUGS.values() if b.program == "display"]
    assert {"double-gamma", "gamma-2.2", "clamp-tonemap"} <= set(display_bugs)
    for name in display_bugs:
        _, correct, buggy = bug_pair(spec, name)
        assert same_radiance(spec, buggy) and same_radiance(correct, buggy)
        for s, aovs in ((correct, True), (buggy, False)):
            got = compare.render_chart(s, aovs=aovs, keep=True).result
            alone = real(default_session(), s, aovs=aovs, hdr=False)
            np.testing.assert_array_equal(got.image, alone.image, err_msg=f"{name}: {s.bugs} {s.exposure}")
            for aov in ("row", "col") if aovs else ():
                np.testing.assert_array_equal(got.aov[aov], alone.aov[aov])
            assert got.hdr is None and got.aov.keys() == ({"row", "col"} if aovs else set())
    assert drawn == [spec]                        # one chart drawn; every other one redisplayed
    chart_bug = bug_pair(spec, "metal-diffuse")[2]
    assert not same_radiance(spec, chart_bug)
    compare.render_chart(chart_bug, keep=True)
    assert drawn == [spec, chart_bug]


def test_a_catalog_made_with_helper_processes_is_the_one_made_on_one_core(tmp_path):
    """With cores to spare, `compare --bugs` hands each card (its FLIP, panels and layout) to a
    helper process as soon as its pair is drawn (workers.helper_pool); pinned to one CPU it
    makes every card itself. Both sheets are the same, pixel for pixel and in their metadata."""
    from sdfpbr.workers import helpers
    names = ["metal-diffuse", "double-gamma", "unsquared-roughness", "gamma-2.2"]
    if not helpers(len(names)):
        pytest.skip("one core (or no worker processes here): no helpers to compare with")
    sheets = {}
    for where, pin in (("helpers", None),
                       ("one core", lambda: os.sched_setaffinity(0, {min(os.sched_getaffinity(0))}))):
        out = tmp_path / f"{where}.png"
        done = subprocess.run([sys.executable, "-m", "sdfpbr", "compare", "--bugs", ",".join(names),
                               "--quality", "draft",
                               "--rows", "2", "--cols", "2", "--panel-size", "96", "-o", str(out)],
                              capture_output=True, text=True, preexec_fn=pin)
        assert done.returncode == 0, done.stderr
        with Image.open(out) as image:
            sheets[where] = (np.asarray(image), dict(image.text))
    np.testing.assert_array_equal(sheets["helpers"][0], sheets["one core"][0])
    assert sheets["helpers"][1] == sheets["one core"][1]


def test_a_differences_mean_leaves_the_cells_borders_out():
    """The cells' page-colour borders are the same pixels in both renders: the mean is over the
    rest of the image (the map keeps them, with what FLIP's filters spread onto them from the
    cells), so it reads as the cells' error."""
    from sdfpbr.shading.plan import chart_frame
    spec = make_spec(width=192, height=192, quality="draft")          # the cells stage: 38-px cells
    d = compare_bug(spec, "unsquared-roughness").differences[0]
    border = chart_frame(spec).border_mask()
    assert border.any()
    assert d.mean == pytest.approx(d.error_map[~border].mean(dtype=np.float64), rel=1e-12)
    assert d.mean > d.error_map.mean(dtype=np.float64)
    # Borders on one side only: they are a difference, counted.
    plain = compare_specs(spec, make_spec(spec, cell_borders=False)).differences[0]
    assert plain.mean == pytest.approx(plain.error_map.mean(dtype=np.float64), rel=1e-12) and plain.mean > 0


@pytest.mark.parametrize("args, line", [
    (["sweep", "tonemap", "--values", "aces,none", "--size", "48x48", "-o", "s.png"],
     "tonemap sweep: 2/2 charts drawn"),
    (["compare", "--bugs", "double-gamma,unsquared-roughness", "--size", "48x48", "-o", "b.png"],
     "bug catalog: 2/2 bugs drawn"),
])
def test_long_sheets_say_how_far_they_are(tmp_path, args, line):
    """`compare --bugs all` ran five minutes printing nothing, `sweep env` one: on a pipe they
    now print a line every few seconds and at the end (a bar on a terminal)."""
    r = subprocess.run([sys.executable, "-m", "sdfpbr", *args], capture_output=True, text=True, cwd=tmp_path,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert line in r.stderr.splitlines()[-1]
