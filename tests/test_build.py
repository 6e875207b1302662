"""`sdfpbr build`: entries, the content-addressed image cache, the manifest and the gallery page.

Each test builds a small gallery (48 px renders) in its own chart directory, cache and output,
through the real GL context."""
import hashlib
import json
import os
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from sdfpbr.features.gallery.entries import collect
from sdfpbr.features.gallery.build import build
from sdfpbr.features.gallery.images import KEY_FIELD, ImageCache, png_key
from sdfpbr.features.gallery.keys import program_sources
from sdfpbr.cache import ArrayCache
from sdfpbr.errors import SpecError
from sdfpbr.shading.plan import render_plan
from sdfpbr.gpu.session import Session
from sdfpbr.spec.chart_spec import make_spec

SMALL = 'size = "48x48"\nrows = 2\ncols = 2\n'

ENTRIES = {
    # a chart with everything on: ground, shadows, IBL, AO
    "plain.toml": SMALL + 'caption = "Plain <b>chart</b> & \\"quotes\\""\n',
    # no ground: no shadows either
    "noground.toml": SMALL + "ground = false\n",
    # no IBL: no AO, no bake
    "noibl.toml": SMALL + "ibl = false\n",
    "sweep.toml": '[sweep]\nfield = "exposure"\nvalues = [-1.0, 1.0]\n[spec]\n' + SMALL + "ground = false\n",
    "bug.toml": 'caption = "Alpha <= r"\n[compare]\nbug = "unsquared-roughness"\n[spec]\n' + SMALL,
}


def make_charts(root: Path, entries=ENTRIES) -> Path:
    charts = root / "charts"
    charts.mkdir()
    for name, text in entries.items():
        (charts / name).write_text(text)
    return charts


@pytest.fixture
def env(tmp_path, monkeypatch):
    """A private image cache and a private, editable copy of the shader modules."""
    shaders = tmp_path / "shaders"
    from sdfpbr.shading.compose import shader_dir
    shutil.copytree(shader_dir(), shaders)
    monkeypatch.setenv("SDFPBR_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("SDFPBR_SHADER_DIR", str(shaders))
    return tmp_path


def images(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.glob("*.png"))}


def test_rebuild_with_no_change_renders_nothing(env):
    charts = make_charts(env)
    out = env / "out"
    first = build(charts, out)
    names = [e["name"] for e in first["images"]]
    assert names == ["bug", "noground", "noibl", "plain", "sweep"]
    assert first["rendered"] == 5 and not any(e["cached"] for e in first["images"])
    before = images(out)
    mtimes = {p.name: p.stat().st_mtime_ns for p in out.glob("*.png")}

    second = build(charts, out)
    assert second["rendered"] == 0 and all(e["cached"] for e in second["images"])
    assert images(out) == before
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.png")} == mtimes   # not even rewritten
    assert [e["key"] for e in second["images"]] == [e["key"] for e in first["images"]]

    forced = build(charts, out, force=True)
    assert forced["rendered"] == 5 and images(out) == before                      # renders are deterministic


def modules_of(spec) -> set[str]:
    """Shader modules of the chart and display programs, straight from the composer."""
    return set(render_plan(spec).chart.modules) | set(render_plan(spec).display.modules)


@pytest.mark.parametrize("module", ["shadow.glsl", "ao.glsl"])
def test_editing_a_shader_module_rerenders_exactly_its_users(env, module):
    charts = make_charts(env)
    out = env / "out"
    build(charts, out)
    items = collect(charts)
    expected = {item.name for item in items if any(module in modules_of(s) for s in item.specs)}
    assert expected and expected != {item.name for item in items}     # the gallery tells them apart

    path = env / "shaders" / module
    path.write_text(path.read_text() + "\n// edited: a new line changes the composed source\n")
    rebuilt = build(charts, out)
    assert {e["name"] for e in rebuilt["images"] if not e["cached"]} == expected
    assert rebuilt["rendered"] == len(expected)
    assert build(charts, out)["rendered"] == 0


def test_program_sources_cover_every_program_a_render_compiles(session, tmp_path):
    """The key hashes program_sources(spec); a real render must compile nothing else, with a
    cold IBL cache (bakes) and a warm one (uploads from the cache)."""
    specs = [make_spec(width=32, height=32, rows=2, cols=2),
             make_spec(width=32, height=32, rows=2, cols=2, ibl=False, ground=False),
             make_spec(width=32, height=32, rows=2, cols=2, env="sky", bugs=("ibl-direct-k",)),
             make_spec(width=32, height=32, rows=2, cols=2, bugs=("fewtap-ibl",)),
             make_spec(width=32, height=32, rows=2, cols=2, textures="procedural", brdf="schlick-ggx")]
    for spec in specs:
        allowed = {src.digest for src in program_sources(spec)}
        for _ in ("cold", "warm"):
            fresh = Session(session.ctx, ArrayCache(tmp_path / "ibl"))
            fresh.render(spec)
            compiled = set(fresh.programs.digests())
            assert compiled and compiled <= allowed, spec


def test_manifest_and_index_list_every_image_escaped(env):
    charts = make_charts(env)
    out = env / "out"
    manifest = build(charts, out)
    on_disk = json.loads((out / "manifest.json").read_text())
    assert on_disk["images"] == json.loads(json.dumps(manifest["images"]))
    by_name = {e["name"]: e for e in on_disk["images"]}
    assert set(by_name) == {p.stem for p in out.glob("*.png")}
    for name, e in by_name.items():
        data = (out / e["image"]).read_bytes()
        assert e["entry"] == f"{name}.toml"
        assert png_key(data) == e["key"] and len(e["key"]) == 64
        assert e["sha256"] == hashlib.sha256(data).hexdigest()
        assert (e["width"], e["height"]) == Image.open(out / e["image"]).size
        assert e["specs"] and all(s["width"] == 48 for s in e["specs"])
        assert e["timings"]["render_s"] > 0
    assert by_name["plain"]["caption"] == 'Plain <b>chart</b> & "quotes"'
    assert by_name["bug"]["params"]["bug"] == "unsquared-roughness"
    assert by_name["sweep"]["params"]["values"] == [-1.0, 1.0]
    assert [s["exposure"] for s in by_name["sweep"]["specs"]] == [-1.0, 1.0]
    assert by_name["noibl"]["params"]["spec"]["ibl"] is False
    # The comparison's caption defaults to the bug's caption unless the entry gives one.
    assert by_name["bug"]["caption"] == "Alpha <= r"

    page = (out / "index.html").read_text()

    class Collect(HTMLParser):
        def __init__(self):
            super().__init__()
            self.srcs, self.text = [], []

        def handle_starttag(self, tag, attrs):
            if tag == "img":
                self.srcs.append(dict(attrs)["src"])
            assert tag != "b", "caption markup must be escaped"

        def handle_data(self, data):
            self.text.append(data)

    parser = Collect()
    parser.feed(page)
    text = "".join(parser.text)
    assert sorted(parser.srcs) == sorted(e["image"] for e in on_disk["images"])
    assert 'Plain <b>chart</b> & "quotes"' in text and "Alpha <= r" in text    # shown, as text
    assert "&lt;b&gt;chart&lt;/b&gt; &amp; &quot;quotes&quot;" in page
    assert "unsquared-roughness" in text and "exposure" in text


def test_png_metadata_specs_are_the_keyed_specs(env):
    """Every spec a sheet says it rendered (PNG metadata) is one the key covers."""
    charts = make_charts(env)
    out = env / "out"
    for e in build(charts, out)["images"]:
        text = Image.open(out / e["image"]).text
        rendered = [json.loads(v) for k, v in text.items() if k == "sdfpbr:spec" or k.startswith("sdfpbr:spec:")]
        keyed = [json.dumps(s, sort_keys=True) for s in e["specs"]]
        assert rendered and all(json.dumps(r, sort_keys=True) in keyed for r in rendered), e["name"]
        assert text[KEY_FIELD] == e["key"]


def test_damaged_cache_entry_and_output_are_replaced(env):
    charts = make_charts(env, {k: ENTRIES[k] for k in ("plain.toml", "noground.toml")})
    out = env / "out"
    first = build(charts, out)
    good = images(out)
    cache = ImageCache()
    plain = next(e for e in first["images"] if e["name"] == "plain")
    entry = cache.path(plain["key"])
    entry.write_bytes(entry.read_bytes()[:200])             # truncated
    assert cache.get(plain["key"]) is None
    (out / "noground.png").write_bytes(b"not a png")        # a damaged output
    again = build(charts, out)
    assert {e["name"]: e["cached"] for e in again["images"]} == {"plain": False, "noground": True}
    assert images(out) == good
    assert png_key(entry.read_bytes()) == plain["key"]


def test_a_removed_entry_loses_its_image_only(env):
    charts = make_charts(env, {k: ENTRIES[k] for k in ("plain.toml", "noground.toml")})
    out = env / "out"
    build(charts, out)
    (out / "notes.png").write_bytes(b"a user's file")
    (charts / "noground.toml").unlink()
    manifest = build(charts, out)
    assert [e["name"] for e in manifest["images"]] == ["plain"]
    assert sorted(p.name for p in out.glob("*.png")) == ["notes.png", "plain.png"]


def test_comparisons_measured_beside_other_entries_are_the_images_each_makes_alone(env):
    """The build renders the comparisons' pairs first and measures their FLIPs in workers while
    the other entries render (images.render_items); every image is still the one its entry
    makes on its own, in a fresh process's state (nothing kept), pixel for pixel."""
    import io

    from sdfpbr.image import metrics
    from sdfpbr.features import compare
    from sdfpbr.features.gallery.images import render_item
    charts = make_charts(env, {**ENTRIES, "sheet.toml": '[compare]\nbugs = ["metal-diffuse", "double-gamma", '
                                                        '"unsquared-roughness", "gamma-2.2"]\n[spec]\n' + SMALL})
    out = env / "out"
    manifest = build(charts, out)
    for entry in manifest["images"]:
        item = next(i for i in collect(charts) if i.name == entry["name"])
        metrics._kept_flips.clear()
        compare._kept.clear()
        alone = render_item(item, entry["key"]).png
        got = np.asarray(Image.open(out / entry["image"]))
        np.testing.assert_array_equal(got, np.asarray(Image.open(io.BytesIO(alone))), err_msg=entry["name"])


def test_each_bug_expands_to_one_image_per_bug(tmp_path):
    from sdfpbr.spec.bugs import BUGS
    charts = make_charts(tmp_path, {"bugs.toml": '[compare]\nbugs = "each"\n[spec]\n' + SMALL})
    items = collect(charts)
    assert [i.name for i in items] == [f"bugs-{name}" for name in BUGS]
    for item, bug in zip(items, BUGS.values()):
        correct, buggy = item.specs
        assert bug.name in buggy.bugs and bug.name not in correct.bugs
        assert item.caption == bug.caption


def test_the_whole_catalog_expands_to_page_sized_sheets(tmp_path):
    """bugs = "all" makes the catalog's pages (compare.catalog_pages), STEM-1.png, STEM-2.png,
    ..., each rendering its own bugs' charts; page = N makes page N alone, as STEM.png."""
    from sdfpbr.features.compare import catalog_pages
    from sdfpbr.features.gallery.images import flip_pairs
    from sdfpbr.spec.bugs import BUGS
    pages = catalog_pages(list(BUGS))
    charts = make_charts(tmp_path, {"s.toml": '[compare]\nbugs = "all"\n[spec]\n' + SMALL})
    sheets = collect(charts)
    assert [i.name for i in sheets] == [f"s-{k}" for k in range(1, len(pages) + 1)]
    for item, page in zip(sheets, pages):
        assert item.kind == "bug-sheet" and item.params["bugs"] == page
        assert [name for _, name in flip_pairs(item)] == page
        assert {s.bugs for s in item.specs} == {()} | {(name,) for name in page}   # its own charts only
    assert len({i.canonical for i in sheets}) == len(sheets)                         # a key each
    (charts / "s.toml").write_text('[compare]\nbugs = "all"\npage = 2\n[spec]\n' + SMALL)
    (alone,) = collect(charts)
    assert alone.name == "s" and alone.canonical == sheets[1].canonical
    for page, needle in (("0", "from 1 to"), ('"2"', "from 1 to"), ("true", "from 1 to")):
        (charts / "s.toml").write_text(f'[compare]\nbugs = "all"\npage = {page}\n[spec]\n' + SMALL)
        with pytest.raises(SpecError, match=needle):
            collect(charts)
    (charts / "s.toml").write_text('[compare]\nbugs = "each"\npage = 1\n[spec]\n' + SMALL)
    with pytest.raises(SpecError, match="page goes with bugs"):
        collect(charts)


def test_entry_paths_are_relative_to_the_entry(tmp_path):
    charts = make_charts(tmp_path, {"ab.toml": '[compare]\na = "specs/x.toml"\nb = "specs/y.toml"\n'
                                               '[spec]\nsize = "48x48"\n'})
    (charts / "specs").mkdir()
    (charts / "specs" / "x.toml").write_text('tonemap = "aces"\n')
    (charts / "specs" / "y.toml").write_text('tonemap = "neutral"\n')
    np.save(charts / "env.npy", np.ones((8, 16, 3), np.float32))
    (charts / "lit.toml").write_text(SMALL + 'env = "env.npy"\n')
    items = {i.name: i for i in collect(charts)}
    a, b = items["ab"].specs
    assert (a.tonemap, b.tonemap, a.width, b.width) == ("aces", "neutral", 48, 48)
    assert items["ab"].labels == ("x", "y")
    assert Path(items["lit"].specs[0].env) == charts / "env.npy"


def cli(*args, **kw):
    return subprocess.run([sys.executable, "-m", "sdfpbr", *args], capture_output=True, text=True, **kw)


@pytest.mark.parametrize("name, text, needle", [
    ("broken.toml", "rows = = 2\n", "malformed TOML"),
    ("typo.toml", 'roughnes = "0:1"\n', "did you mean 'roughness'"),
    ("bug.toml", '[compare]\nbug = "unsquared-roughnes"\n', "unknown bug"),
    ("both.toml", '[compare]\nbug = "double-gamma"\na = "x.toml"\nb = "y.toml"\n', "exactly one of"),
    ("sweep.toml", '[sweep]\nfield = "tonemapp"\nvalues = ["aces"]\n', "unknown spec field 'tonemapp'"),
    ("values.toml", '[sweep]\nfield = "tonemap"\nvalues = []\n', "non-empty list"),
    ("field.toml", '[sweep]\nfield = "nosuch"\n', "unknown spec field 'nosuch'"),
    ("novalues.toml", '[sweep]\nfield = "rows"\n', "[sweep] over rows needs values"),
    ("extra.toml", 'caption = "x"\nsize = "48x48"\n[spec]\nrows = 2\n', "[spec] belongs to"),
    ("missing.toml", '[compare]\na = "nowhere.toml"\nb = "nowhere.toml"\n', "does not exist"),
])
def test_bad_entry_is_one_line_naming_the_file_exit_2_nothing_written(tmp_path, name, text, needle):
    charts = make_charts(tmp_path, {"good.toml": SMALL, name: text})
    out = tmp_path / "out"
    r = cli("build", str(charts), "-o", str(out), env={**os.environ, "SDFPBR_CACHE_DIR": str(tmp_path / "cache")})
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and name in lines[0] and "Traceback" not in r.stderr
    assert not out.exists() and not (tmp_path / "cache").exists()


def test_an_entry_that_fails_to_render_leaves_the_last_build_as_it_was(tmp_path):
    """An environment file that reads as valid TOML but breaks at render (truncated after
    the build checked its entries): exit 2 in one line, and the folder keeps the last build's
    images and manifest, not a changed image under an old manifest."""
    import numpy as np
    charts = make_charts(tmp_path, {"a.toml": SMALL, "z.toml": SMALL + 'env = "env.npy"\n'})
    np.save(charts / "env.npy", np.ones((4, 8, 3), np.float32))
    out, env = tmp_path / "out", {**os.environ, "SDFPBR_CACHE_DIR": str(tmp_path / "cache")}
    assert cli("build", str(charts), "-o", str(out), env=env).returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    (charts / "a.toml").write_text(SMALL + "exposure = 1.0\n")
    (charts / "env.npy").write_bytes((charts / "env.npy").read_bytes()[:100])   # the header, no data
    r = cli("build", str(charts), "-o", str(out), env=env)
    report = [line for line in r.stderr.splitlines() if not line.startswith("[")]   # progress lines
    assert r.returncode == 2 and len(report) == 1 and "env.npy" in report[0] and "Traceback" not in r.stderr, r.stderr
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_bad_directory_and_output(tmp_path):
    r = cli("build", str(tmp_path / "nowhere"), "-o", str(tmp_path / "out"))
    assert r.returncode == 2 and "does not exist" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    empty = tmp_path / "empty"
    empty.mkdir()
    r = cli("build", str(empty), "-o", str(tmp_path / "out"))
    assert r.returncode == 2 and "no *.toml" in r.stderr
    charts = make_charts(tmp_path, {"good.toml": SMALL})
    (tmp_path / "file").write_text("x")
    r = cli("build", str(charts), "-o", str(tmp_path / "file"))
    assert r.returncode == 2 and "not a directory" in r.stderr
    assert (tmp_path / "file").read_text() == "x"
    r = cli("build", str(charts), "-o", str(tmp_path / "a" / "b"))
    assert r.returncode == 2 and "does not exist" in r.stderr and not (tmp_path / "a").exists()
    assert not (tmp_path / "out").exists()


def test_cli_build_reports_progress_and_counts(tmp_path):
    charts = make_charts(tmp_path, {"plain.toml": SMALL, "noground.toml": SMALL + "ground = false\n"})
    env = {**os.environ, "SDFPBR_CACHE_DIR": str(tmp_path / "cache")}
    out = tmp_path / "out"
    r = cli("build", str(charts), "-o", str(out), env=env)
    assert r.returncode == 0, r.stderr
    assert "2 images (2 rendered, 0 cached)" in r.stdout
    assert "[1/2]" in r.stderr and "[2/2]" in r.stderr and "rendered in" in r.stderr
    r = cli("build", str(charts), "-o", str(out), env=env)
    assert r.returncode == 0 and "2 images (0 rendered, 2 cached)" in r.stdout


def test_the_key_follows_the_python_that_makes_images_only():
    from sdfpbr.features.gallery.keys import image_modules
    names = {p.stem for p in image_modules()}
    assert {"render", "api", "compare", "layout", "ibl", "compose", "bugs", "textures"} <= names
    assert not names & {"cli", "mirror", "build", "sphinxext"}


def test_the_project_gallery_covers_the_issue_list():
    """charts/: the default chart, the metals, every bug (own image + the catalog's pages), the
    tone mapper, exposure and environment sweeps, the furnace, a chart laid onto a page; parsed,
    not rendered."""
    from sdfpbr.features.compare import catalog_pages
    from sdfpbr.spec.bugs import BUGS
    from sdfpbr.spec.chart_spec import ENV_PRESETS, MATERIAL_PRESETS, TONEMAPPERS
    items = {i.name: i for i in collect(Path(__file__).resolve().parent.parent / "charts")}
    catalog = [f"bug-catalog-{k}" for k in range(1, len(catalog_pages(list(BUGS))) + 1)]
    assert {"default", "materials", "furnace", "tonemappers", "exposure", "environments", *catalog} <= set(items)
    assert {f"bugs-{name}" for name in BUGS} <= set(items)
    assert [n for page in catalog for n in items[page].params["bugs"]] == list(BUGS)
    assert set(items["materials"].specs[0].row_materials) == set(MATERIAL_PRESETS)
    assert items["tonemappers"].sweep_values == TONEMAPPERS          # every tone mapper, read from the table
    assert items["environments"].sweep_values == ENV_PRESETS
    assert items["exposure"].sweep_field == "exposure" and items["environments"].sweep_field == "env"
    furnace = items["furnace"].specs[0]
    assert (furnace.env, furnace.lights, furnace.ground, furnace.ao, furnace.base_color) == (
        "uniform", (), False, False, (1.0, 1.0, 1.0))
    page = items["on-a-page"].specs[0]
    assert page.transparent and page.backdrop == (0.96, 0.95, 0.92)
    assert all(max(s.width, s.height) <= 1024 for i in items.values() for s in i.specs)


def test_comparisons_composed_in_workers_are_the_images_each_makes_alone(env):
    """With a core to spare, each comparison is composed (its FLIP measured, its page laid out
    and encoded) in a worker process from the renders this process made, the catalog last
    (images.render_items); every image is the one its entry makes alone in a fresh process's
    state, pixel for pixel, and this process measured none of their FLIPs."""
    import io

    from sdfpbr.image import metrics
    from sdfpbr.features import compare
    from sdfpbr.features.gallery.images import render_item
    from sdfpbr.workers import HELPERS_FROM, helpers
    bugs = ["metal-diffuse", "double-gamma", "unsquared-roughness", "gamma-2.2"]
    if not helpers(len(bugs) + 1):
        pytest.skip("one core (or no worker processes here): the comparisons are composed in-process")
    assert len(bugs) + 1 >= HELPERS_FROM
    entries = {f"bug-{name}.toml": f'[compare]\nbug = "{name}"\n[spec]\n' + SMALL for name in bugs}
    entries["sheet.toml"] = f"[compare]\nbugs = {json.dumps(bugs)}\n[spec]\n" + SMALL
    entries["plain.toml"] = ENTRIES["plain.toml"]
    charts = make_charts(env, entries)
    metrics._kept_flips.clear()
    compare._kept.clear()
    manifest = build(charts, env / "out")
    assert len(metrics._kept_flips) == 0          # every FLIP was measured in a worker
    assert manifest["rendered"] == len(entries)
    for entry in manifest["images"]:
        item = next(i for i in collect(charts) if i.name == entry["name"])
        metrics._kept_flips.clear()
        compare._kept.clear()
        alone = render_item(item, entry["key"]).png
        got = np.asarray(Image.open(env / "out" / entry["image"]))
        np.testing.assert_array_equal(got, np.asarray(Image.open(io.BytesIO(alone))), err_msg=entry["name"])


def test_items_that_share_a_chart_go_to_one_worker_together():
    """A parallel build hands a worker the items that render a spec in common, so the renders
    and FLIP maps it keeps serve them all: the bug catalog's pages with the bug comparisons (the
    same correct and buggy charts), the exposure and tone-mapper sweeps (the same ACES, 0 EV chart)."""
    from sdfpbr.features.compare import catalog_pages
    from sdfpbr.spec.bugs import BUGS
    from sdfpbr.features.gallery.build import work_groups
    items = collect(Path(__file__).resolve().parent.parent / "charts")
    groups = work_groups(items)
    names = [[item.name for item in group] for group in groups]
    assert sorted(n for group in names for n in group) == sorted(item.name for item in items)   # each once
    order = [item.name for item in items]
    assert all(group == sorted(group, key=order.index) for group in names)                       # entry order
    for k, page in enumerate(catalog_pages(list(BUGS)), 1):   # each page with its bugs' comparisons
        group = next(set(g) for g in names if f"bug-catalog-{k}" in g)
        assert {f"bugs-{bug}" for bug in page} <= group
    assert "bug-catalog-1" in names[0] and {i.kind for i in groups[0]} == {"bug-sheet", "compare"}   # largest first
    assert {"exposure", "tonemappers"} in [set(group) for group in names]
    text = {item.name: {json.dumps(s.to_dict(), sort_keys=True, default=str) for s in item.specs} for item in items}
    for a in groups:                                                  # and groups share no chart
        for b in groups:
            if a is not b:
                assert not set().union(*(text[i.name] for i in a)) & set().union(*(text[i.name] for i in b))


def test_the_gallery_page_leads_with_the_default_chart():
    from sdfpbr.features.gallery.page import page_order
    images = [{"name": n, "kind": k} for n, k in (("bug-catalog", "bug-sheet"), ("bugs-x", "compare"),
                                                  ("exposure", "sweep"), ("default", "chart"), ("furnace", "chart"))]
    assert [i["name"] for i in page_order(images)] == ["default", "furnace", "exposure", "bugs-x", "bug-catalog"]


def test_the_gallery_page_has_a_section_per_kind_and_cards_as_wide_as_their_images():
    from sdfpbr.features.gallery.page import COLUMN_PX, FULL_ROW_COLUMNS, SECTIONS, columns_needed, gallery_html

    def image(name, kind, width):
        return {"name": name, "kind": kind, "width": width, "height": 300, "image": f"{name}.png", "entry": "e.toml",
                "caption": "", "params": {}, "specs": []}
    manifest = {"images": [image("cat-1", "bug-sheet", 1033), image("x", "sweep", 900), image("default", "chart", 459),
                           image("bugs-a", "compare", 1700)],
                "charts": "charts", "sdfpbr": "0", "gl_renderers": ["gl"]}
    page = gallery_html(manifest)

    class Collect(HTMLParser):
        def __init__(self):
            super().__init__()
            self.order, self.spans = [], {}

        def handle_starttag(self, tag, attrs):
            a = dict(attrs)
            if tag == "h2":
                self.order.append(a["id"])
            if tag == "figure":
                self.order.append(a["id"])
                self.spans[a["id"]] = a.get("class", "")

    parser = Collect()
    parser.feed(page)
    kinds = [kind for kind, _, _ in SECTIONS]
    assert parser.order == ["section-chart", "default", "section-sweep", "x", "section-compare", "bugs-a",
                            "section-bug-sheet", "cat-1"]
    assert kinds.index("chart") < kinds.index("sweep") < kinds.index("compare") < kinds.index("bug-sheet")
    # A card spans the columns its image needs, so a sheet is shown near its own size.
    assert [columns_needed(w) for w in (COLUMN_PX, 2 * COLUMN_PX, 10 * COLUMN_PX)] == [1, 2, FULL_ROW_COLUMNS]
    assert parser.spans == {"default": "", "x": "span2", "bugs-a": f"span{FULL_ROW_COLUMNS}", "cat-1": "span2"}
    assert "align-items: start" in page          # a tall card does not stretch its row
    assert 'style="max-width: 459px"' in page    # nor is an image drawn larger than it is


def test_gallery_summaries_print_clean_values():
    from sdfpbr.features.gallery.page import param_text
    assert param_text({"lights": (), "metallic": (1.0, 1.0), "roughness": (0.0, 1.0)}) == \
        "lights = none; metallic = 1.0; roughness = 0.0, 1.0"


def test_a_flipped_byte_anywhere_in_a_cached_image_is_caught(env):
    charts = make_charts(env, {"plain.toml": ENTRIES["plain.toml"]})
    entry = build(charts, env / "out")["images"][0]
    data = ImageCache().path(entry["key"]).read_bytes()
    assert png_key(data) == entry["key"]
    for pos in range(8, len(data), max(1, len(data) // 97)):   # past the signature, every chunk kind
        damaged = data[:pos] + bytes([data[pos] ^ 0x10]) + data[pos + 1:]
        assert png_key(damaged) is None, f"flipped byte {pos} of {len(data)} went unnoticed"
    assert png_key(data + b"junk") is None and png_key(data[:-1]) is None


def test_remembered_keys_are_the_exact_keys_and_a_bad_memo_is_rebuilt(env):
    from sdfpbr.features.gallery.keys import gl_renderers, item_key, item_keys
    charts = make_charts(env, {k: ENTRIES[k] for k in ("plain.toml", "sweep.toml")})
    items = collect(charts)
    renderers = gl_renderers(items)
    exact = {item.name: item_key(item, renderers) for item in items}
    memo = env / "keys.json"
    assert item_keys(items, renderers, memo) == exact           # composed, then remembered
    assert item_keys(items, renderers, memo) == exact           # remembered
    assert len(json.loads(memo.read_text())) == len(items)
    memo.write_text("{not json")                                      # an unreadable memo is rebuilt
    assert item_keys(items, renderers, memo) == exact
    shader = env / "shaders" / "shade.glsl"                           # a touched module recomposes
    shader.write_text(shader.read_text() + "\n// edited\n")
    edited = item_keys(items, renderers, memo)
    assert edited == {item.name: item_key(item, renderers) for item in items} != exact


STAMPED = {"plain.toml": SMALL, "sweep.toml": ENTRIES["sweep.toml"], "lit.toml": SMALL + 'env = "env.npy"\n'}

# Run in a fresh process: the manifest, and whether the build loaded the entries' modules.
STAMP_PROBE = """import json, sys
from sdfpbr.features.gallery.build import build
manifest = build(sys.argv[1], sys.argv[2])
print(json.dumps([manifest, sorted(m for m in ("numpy", "sdfpbr.spec", "sdfpbr.gpu.session") if m in sys.modules)]))
"""


def probe(charts: Path, out: Path) -> tuple[dict, list]:
    r = subprocess.run([sys.executable, "-c", STAMP_PROBE, str(charts), str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    manifest, loaded = json.loads(r.stdout)
    return manifest, loaded


def same_build(a: dict, b: dict) -> bool:
    """The same manifest.json but for the time taken."""
    return json.dumps({**a, "elapsed_s": 0}) == json.dumps({**b, "elapsed_s": 0})


def test_a_rebuild_with_nothing_changed_is_answered_by_its_stamp(env):
    """The second build reads no entry (no numpy, no spec, no GL) and writes what a full build
    with nothing to render writes; every kind of input change takes the full build again."""
    from sdfpbr.features.gallery.stamp import stamp_path
    charts = make_charts(env, STAMPED)
    np.save(charts / "env.npy", np.full((8, 16, 3), 0.5, np.float32))
    out = env / "out"
    first = build(charts, out)
    assert first["rendered"] == 3
    answered, loaded = probe(charts, out)
    assert loaded == []                                               # nothing heavy was imported
    stamp = stamp_path(ImageCache().dir, charts, out, None)
    stamp.unlink()
    full = build(charts, out)                                         # the same build, done in full
    assert full["rendered"] == 0 and same_build(answered, full)
    again, loaded = probe(charts, out)                                # and stamped again
    assert loaded == [] and same_build(again, full)

    # A file an entry names, edited to the same size with its mtime put back: read by content.
    before = images(out)
    st = (charts / "env.npy").stat()
    np.save(charts / "env.npy", np.full((8, 16, 3), 2.0, np.float32))
    os.utime(charts / "env.npy", ns=(st.st_atime_ns, st.st_mtime_ns))
    assert (charts / "env.npy").stat().st_size == st.st_size
    manifest, loaded = probe(charts, out)
    assert "numpy" in loaded and [e["name"] for e in manifest["images"] if not e["cached"]] == ["lit"]
    assert images(out)["lit.png"] != before["lit.png"]
    assert probe(charts, out)[1] == []                                # stamped again

    (charts / "plain.toml").write_text(SMALL + "exposure = 0.5\n")        # an entry edited: -v says so
    r = cli("build", str(charts), "-o", str(out), "-v")
    assert r.returncode == 0 and f"full build: {charts / 'plain.toml'} changed" in r.stderr, r.stderr
    assert "(1 rendered, 2 cached)" in r.stdout and "plain.png  rendered" in r.stderr
    (charts / "new.toml").write_text(SMALL + "ground = false\n")          # an entry added
    assert [e["name"] for e in probe(charts, out)[0]["images"] if not e["cached"]] == ["new"]
    shader = env / "shaders" / "tonemap.glsl"                              # a shader module edited
    shader.write_text(shader.read_text() + "\n// edited\n")
    assert probe(charts, out)[0]["rendered"] == 4
    assert probe(charts, out)[1] == []

    good = images(out)
    (out / "sweep.png").unlink()                                      # an output removed: from the cache
    manifest, loaded = probe(charts, out)
    assert manifest["rendered"] == 0 and loaded and images(out) == good
    key = next(e["key"] for e in manifest["images"] if e["name"] == "plain")
    ImageCache().path(key).unlink()                                   # a cache entry removed: rendered
    manifest, loaded = probe(charts, out)
    assert [e["name"] for e in manifest["images"] if not e["cached"]] == ["plain"] and images(out) == good

    r = subprocess.run([sys.executable, "-c", STAMP_PROBE, str(charts), str(out)], capture_output=True, text=True,
                       env={**os.environ, "MESA_DEBUG": "silent"})    # a variable that steers GL
    assert r.returncode == 0 and "numpy" in json.loads(r.stdout)[1]


def test_an_input_log_records_what_is_read_by_content(tmp_path):
    from sdfpbr.features.gallery.stamp import InputLog, fingerprint
    (tmp_path / "d").mkdir()
    read, written, cached = tmp_path / "d" / "in.txt", tmp_path / "out.txt", tmp_path / "cache" / "c.txt"
    read.write_text("abc")
    cached.parent.mkdir()
    cached.write_text("c")
    with InputLog(tmp_path / "cache") as log:
        read.read_text()
        written.write_text("x")
        cached.read_text()
        sorted((tmp_path / "d").glob("*"))
        if os.path.exists("/proc/self/stat"):
            open("/proc/self/stat").read()                            # a kernel view: not an input
    assert set(log.paths) == {str(read), str(tmp_path / "d")}
    assert log.paths[str(read)] == fingerprint(str(read)) and log.paths[str(read)][0] == "file"
    listing = fingerprint(str(tmp_path / "d"))
    (tmp_path / "d" / "more.txt").write_text("")
    assert fingerprint(str(tmp_path / "d")) != listing
    st = read.stat()
    read.write_text("abd")                                            # same size, mtime put back
    os.utime(read, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert fingerprint(str(read)) != log.paths[str(read)]
    assert fingerprint(str(tmp_path / "missing")) is None


def test_shards_merge_into_the_gallery_a_single_build_makes(env):
    entries = {k: ENTRIES[k] for k in ("plain.toml", "noground.toml", "noibl.toml", "sweep.toml")}
    charts = make_charts(env, entries)
    whole = build(charts, env / "whole")
    parts = [env / f"part{i}" for i in (1, 2, 3)]
    shards = [build(charts, part, shard=(i, 3)) for i, part in enumerate(parts, start=1)]
    names = [e["name"] for e in whole["images"]]
    assert [[e["name"] for e in m["images"]] for m in shards] == [names[0::3], names[1::3], names[2::3]]
    assert not (parts[0] / "index.html").exists()               # a shard is not a page
    from sdfpbr.features.gallery.build import merge
    merged = merge(charts, parts, env / "site")
    assert [e["name"] for e in merged["images"]] == names
    assert images(env / "site") == images(env / "whole")
    assert (env / "site" / "index.html").is_file()

    with pytest.raises(SpecError, match="no shard holds"):
        merge(charts, parts[:2], env / "site2")
    damaged = parts[1] / f"{shards[1]['images'][0]['name']}.png"
    damaged.write_bytes(damaged.read_bytes()[:-10])
    with pytest.raises(SpecError, match="sha256 differs"):
        merge(charts, parts, env / "site3")
    with pytest.raises(SpecError, match="in both"):
        merge(charts, [parts[0], parts[0]], env / "site4")
    for text, why in (("{}", "it is not a table"), ("[]", "it is not a table"), ("{", "it is not JSON"),
                      ('{"images": "x"}', "it is not a table"), ('{"images": [1]}', "it is not a table"),
                      ('{"images": [], "gl_renderers": 3}', "its gl_renderers is not a list")):
        (env / "bad").mkdir(exist_ok=True)
        (env / "bad" / "manifest.json").write_text(text)
        with pytest.raises(SpecError, match=f"holds no readable manifest.json of a build shard: {why}"):
            merge(charts, [env / "bad"], env / "site5")
    assert not (env / "site2").exists() and not (env / "site3").exists()


@pytest.mark.parametrize("args, needle", [(["--shard", "0/2"], "1 <= I <= N"), (["--shard", "x"], "I/N"),
                                          (["--merge", "a", "--force"], "renders nothing")])
def test_shard_and_merge_flags_are_checked(tmp_path, args, needle):
    charts = make_charts(tmp_path, {"plain.toml": ENTRIES["plain.toml"]})
    r = subprocess.run([sys.executable, "-m", "sdfpbr", "build", str(charts), "-o", str(tmp_path / "o"), *args],
                       capture_output=True, text=True)
    assert r.returncode == 2 and needle in r.stderr and r.stderr.count("\n") == 1
