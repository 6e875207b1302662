"""`sdfpbr bench`: the quick run end to end, the Shadertoy baseline, the ablation's claims,
bad arguments."""
import json
import math
import subprocess
import sys
from pathlib import Path

import moderngl
import numpy as np
import pytest

from sdfpbr.devtools.bench import ablation, accuracy, cold, end_to_end, report, suite, timing
from sdfpbr.devtools.baseline import build_program, extract_glsl, load_shadertoy, set_shadertoy_uniforms
from sdfpbr.cli.main import build_parser, main, spec_from_args
from sdfpbr.errors import ShaderCompileError, SpecError
from sdfpbr.shading.plan import render_plan

# A Shadertoy-style document as people publish them: prose, an old-style `void main()` sphere
# raymarcher writing gl_FragColor, and prose with GLSL words after it. `--baseline` reads such a
# file from wherever the user keeps it; the tests write this one. (The `seed002` quality preset,
# the same approach drawn on the chart's own scene, is tested in test_bugs.py.)
SHADERTOY_DOCUMENT = """A small sphere-tracing tutorial: a grid of spheres, a sky and a Blinn highlight.

precision mediump float;
uniform vec2 iResolution;
uniform float iTime;

float map(vec3 p) {
    vec2 cell = clamp(floor(p.xy / 2.5 + 0.5), vec2(-2.0), vec2(2.0));
    return length(p - vec3(cell * 2.5, 0.0)) - 1.0;
}

void main() {
    vec2 uv = (2.0 * gl_FragCoord.xy - iResolution) / iResolution.y;
    vec3 ro = vec3(0.0, 0.0, 9.0), rd = normalize(vec3(uv, -1.2));
    float t = 0.0;
    for (int i = 0; i < 100; i++) {
        float d = map(ro + rd * t);
        if (d < 1e-3 || t > 40.0) break;
        t += d;
    }
    vec3 col = mix(vec3(0.2, 0.3, 0.5), vec3(0.8, 0.9, 1.0), 0.5 + 0.5 * rd.y);
    if (t < 40.0) {
        vec3 p = ro + rd * t;
        vec2 e = vec2(1e-3, 0.0);
        vec3 n = normalize(vec3(map(p + e.xyy) - map(p - e.xyy), map(p + e.yxy) - map(p - e.yxy),
                                map(p + e.yyx) - map(p - e.yyx)));
        vec3 l = normalize(vec3(-0.5, 0.7, 0.5));
        col = vec3(0.8, 0.3, 0.08) * max(dot(n, l), 0.0) + pow(max(dot(n, normalize(l - rd)), 0.0), 64.0);
    }
    gl_FragColor = vec4(col, 1.0);
}

Next time: path tracing after Kajiya, where void main() { ... } gathers light over many bounces.
"""


@pytest.fixture(scope="module")
def shadertoy_document(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("shadertoy") / "spheres.txt"
    path.write_text(SHADERTOY_DOCUMENT)
    return path


# --- the quick run, end to end -------------------------------------------------------------------

# The quick run at half its size and one repeat: what these tests check (every row, every
# column finite, the plot, the heat maps, the baseline) does not depend on either. Without its
# cold-start columns: they were most of its time (four fresh processes a row, two of them
# compiling every shader with Mesa's cache off) and test_cold_columns_time_fresh_processes
# checks them on one row.
QUICK_OVERRIDES = dict(width=128, height=128, repeats=1)


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory, cache_dir, shadertoy_document):
    out = tmp_path_factory.mktemp("bench") / "out.json"
    cmd = [sys.executable, "-m", "sdfpbr", "bench", "--quick", "--json", str(out), "-q",
           "--size", f"{QUICK_OVERRIDES['width']}x{QUICK_OVERRIDES['height']}",
           "--repeats", str(QUICK_OVERRIDES["repeats"]), "--no-cold",
           "--heatmaps", str(out.parent / "heat"), "--baseline", str(shadertoy_document)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return out, json.loads(out.read_text()), proc.stdout


@pytest.mark.requires_extra("matplotlib")   # the quick run plots and computes FLIP
def test_quick_json_has_every_scene_preset_row_with_finite_numbers(quick_report):
    path, report, stdout = quick_report
    cfg = suite.BenchConfig.quick(**QUICK_OVERRIDES)
    rows = {(r["scene"], r["preset"]): r for r in report["rows"] if r["preset"] != "baseline"}
    assert set(rows) == {(s, p) for s in cfg.scenes for p in cfg.presets}
    for (scene, preset), row in rows.items():
        for key in suite.REQUIRED_KEYS[2:]:
            if key in cold.COLD_COLUMNS:
                assert row[key] is None, (scene, preset, key, row[key])   # --no-cold
            else:
                assert isinstance(row[key], (int, float)) and math.isfinite(row[key]), (scene, preset, key, row[key])
        assert row["render_ms"] > 0 and row["compile_ms"] > 0
        assert 0.0 < row["flip_mean"] < 1.0 and row["rel_rmse"] >= 0.0
        assert (row["width"], row["height"]) == (cfg.width, cfg.height)
        # Independently: the composed source the row measured.
        spec = suite.scene_spec(scene, cfg, preset)
        assert row["source_bytes"] == len(render_plan(spec).chart.text.encode())
        assert row["spheres"] == spec.rows * spec.cols
        # The timed draw reproduced the render the errors were computed from.
        assert row["draw_check"] < 1e-4
        assert len(row["flip_cells"]) == spec.rows and len(row["flip_cells"][0]) == spec.cols
        # The reference's noise floor: two seeds of one scene differ, by less than the chart does
        # only if the reference can judge it; the warm-up says whether draw times settled.
        assert 0.0 < row["ref_noise_flip"] < 1.0
        assert row["ref_judges"] == (row["flip_mean"] >= accuracy.NOISE_MARGIN * row["ref_noise_flip"])
        # The spheres' mean-luminance bias against the two seeds' mean, and its own noise.
        cells = np.array(row["bias_cells"], float)
        assert cells.shape == (spec.rows, spec.cols) and row["bias_worst"] == pytest.approx(np.nanmax(np.abs(cells)))
        assert 0.0 < row["bias_noise"] < 0.5
        assert row["bias_judged"] == (row["bias_worst"] >= accuracy.NOISE_MARGIN * row["bias_noise"])
        assert row["warmup_draws"] >= cfg.warmup and isinstance(row["settled"], bool)
    noise = {s: {r["ref_noise_flip"] for r in rows.values() if r["scene"] == s} for s in cfg.scenes}
    assert all(len(v) == 1 for v in noise.values())   # one floor per scene
    assert "render ms" in stdout and "FLIP" in stdout
    hint = f"--ref-samples {2 * cfg.ref_samples} goes on from the cached {cfg.ref_samples}-sample ones"
    assert (hint in stdout) == any(not r["ref_judges"] for r in rows.values()), stdout
    assert path.with_suffix(".png").stat().st_size > 1000    # the time-vs-error plot
    heat = sorted(p.name for p in (path.parent / "heat").iterdir())
    assert heat == sorted(f"flip_{s}_{p}.png" for s, p in rows)


def test_cold_columns_time_fresh_processes(tmp_path):
    """Without --no-cold each row times fresh `sdfpbr chart` processes: with Mesa's shader cache
    off and an empty sdfpbr cache, with it filled, and a warm start (cold.cold_times)."""
    out = tmp_path / "cold.json"
    cmd = [sys.executable, "-m", "sdfpbr", "bench", "--scenes", "bare", "--presets", "draft", "--size", "32x32",
           "--repeats", "1", "--no-reference", "--no-plot", "--json", str(out), "-q"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    (row,) = json.loads(out.read_text())["rows"]
    for key in cold.COLD_COLUMNS:
        assert isinstance(row[key], float) and math.isfinite(row[key]) and row[key] > 0.0, (key, row[key])


@pytest.mark.requires_extra("matplotlib")   # through quick_report
def test_quick_baseline_row(quick_report):
    _, report, _ = quick_report
    (row,) = [r for r in report["rows"] if r["preset"] == "baseline"]
    assert row["render_ms"] > 0 and row["compile_ms"] > 0
    assert row["flip_mean"] is None and row["width"] == QUICK_OVERRIDES["width"]
    assert row["entry_point"] == "main"


# --- the Shadertoy baseline --------------------------------------------------------------------------

def _draw(ctx, program, w, h) -> np.ndarray:
    tex = ctx.texture((w, h), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[tex])
    fbo.use()
    ctx.vertex_array(program, []).render(moderngl.TRIANGLES, vertices=3)
    return np.frombuffer(tex.read(), np.float32).reshape(h, w, 4)


def test_shadertoy_document_extracts_and_renders(ctx, shadertoy_document):
    src = load_shadertoy(shadertoy_document)
    assert src.entry == "main"
    assert src.code.lstrip().startswith("precision") and src.code.rstrip().endswith("}")
    assert "gl_FragColor = vec4(col, 1.0);" in src.code
    # The prose after the shader (and its GLSL words) is not part of the code.
    assert "Kajiya" not in src.code and src.code.count("void main") == 1
    program = build_program(ctx, src)
    set_shadertoy_uniforms(program, 48, 32)
    assert program["iResolution"].dimension == 2          # the document declares vec2: its type is kept
    img = _draw(ctx, program, 48, 32)
    assert np.isfinite(img).all() and img[..., :3].std() > 0.01
    assert np.allclose(img[..., 3], 1.0)


MARKDOWN = """# A gradient

Some prose before the code, which must not be compiled.

```glsl
// Shadertoy entry point
void mainImage(out vec4 fragColor, in vec2 fragCoord) {
    vec2 uv = fragCoord / iResolution.xy;
    fragColor = vec4(uv, 0.25 + 0.0 * iTime + 0.0 * float(iFrame) + 0.0 * iMouse.x, 1.0);
}
```

More prose afterwards, with `inline code` too.
"""


def test_fenced_mainimage_gets_shadertoy_uniforms(ctx, tmp_path):
    path = tmp_path / "gradient.md"
    path.write_text(MARKDOWN)
    src = load_shadertoy(path)
    assert src.entry == "mainImage" and "prose" not in src.code
    program = build_program(ctx, src)
    w, h = 16, 8
    set_shadertoy_uniforms(program, w, h)
    img = _draw(ctx, program, w, h)          # GL rows bottom-up, as fragCoord counts
    x = (np.arange(w) + 0.5) / w
    y = (np.arange(h) + 0.5) / h
    np.testing.assert_allclose(img[..., 0], np.broadcast_to(x, (h, w)), atol=1e-6)
    np.testing.assert_allclose(img[..., 1], np.broadcast_to(y[:, None], (h, w)), atol=1e-6)
    np.testing.assert_allclose(img[..., 2], 0.25, atol=1e-6)


def test_unfenced_old_style_shader_between_prose():
    text = ("Intro sentence that explains what the shader below is going to draw for us.\n"
            "#version 100\nprecision mediump float;\nuniform vec2 iResolution;\n"
            "void main() {\n  gl_FragColor = texture2D(tex, gl_FragCoord.xy / iResolution);\n}\n"
            "An outro paragraph that talks about the void main() { function } above in words.\n")
    code, entry, line = extract_glsl(text)
    assert entry == "main" and line == 2
    assert code.startswith("#version 100") and code.rstrip().endswith("}") and "outro" not in code


def test_baseline_errors_are_one_line(ctx, tmp_path):
    with pytest.raises(SpecError, match="no GLSL shader"):
        extract_glsl("just words, no shader here", "notes.txt")
    broken = tmp_path / "broken.glsl"
    broken.write_text("void mainImage(out vec4 c, in vec2 p) {\n  c = vec4(undefined_name);\n}\n")
    with pytest.raises(ShaderCompileError, match=r"broken\.glsl:2") as info:
        build_program(ctx, load_shadertoy(broken))
    assert "\n" not in str(info.value)
    with pytest.raises(SpecError, match="does not exist"):
        load_shadertoy(tmp_path / "missing.glsl")


# --- scenes, cold flags, ablation --------------------------------------------------------------------

def test_warm_up_waits_for_draw_times_to_settle():
    """A GPU raising its clocks: draw times fall, then hold; settled only once two windows agree."""
    falling = [9.0 - 0.5 * i for i in range(15)]            # 9 ms down to 2 ms
    assert not timing.settled(falling)
    held = falling + [1.6] * (2 * timing.SETTLE_WINDOW)
    assert timing.settled(held)
    assert not timing.settled(held[:-timing.SETTLE_WINDOW])  # one flat window is not enough
    noisy = [1.5, 1.7, 1.6, 1.65, 1.55, 1.62, 1.58, 1.7, 1.5, 1.6]   # noise, not a trend
    assert timing.SETTLE_WINDOW == 5 and timing.settled(noisy)


@pytest.mark.parametrize("scene", list(suite.SCENES))
def test_cold_flags_give_the_scene_spec(scene, tmp_path):
    cfg = suite.BenchConfig(width=320, height=200)
    flags = cold.cli_flags(suite.scene_overrides(scene), "draft", cfg.width, cfg.height, "auto", str(tmp_path))
    args = build_parser().parse_args(["chart", *flags])
    assert spec_from_args(args) == suite.scene_spec(scene, cfg, "draft")


def test_presets_include_seed002_when_defined():
    from sdfpbr.spec.chart_spec import QUALITY_PRESETS
    assert ("seed002" in suite.available_presets()) == ("seed002" in QUALITY_PRESETS)
    assert suite.available_presets()[:3] == ("draft", "default", "high")


def test_ablation_removes_each_feature_and_absent_features_cost_no_code(session):
    cfg = suite.BenchConfig(width=64, height=64, repeats=1, warmup=0)
    rows = {r["preset"]: r for r in ablation.ablation_rows(session, cfg, lambda line: None)}
    assert rows["ablation:full"]["ratio"] == 1.0
    for feature in ("shadows", "ao", "ibl", "lights"):
        row = rows[f"ablation:{feature}"]
        assert row["removed"], feature                  # the composer dropped its code ...
        assert row["absent_ok"], (feature, row["leftover"])   # ... all of it that runs
        assert row["source_bytes"] < rows["ablation:full"]["source_bytes"]
    for name in suite.ABSENT_PAIRS:
        row = rows[f"absent:{name}"]
        assert row["same_source"], name
        assert row["render_ms"] > 0 and row["without_ms"] > 0
    for row in rows.values():
        assert row["draw_check"] < 1e-4


def test_code_identifiers_ignore_comments_and_count_uses():
    ids = ablation.code_identifiers("// shadow_steps\n#define USE_SHADOWS 0\n"
                                    "float f(float a) { return a * a; } /* b */\n")
    assert ids == {"float": 2, "f": 1, "a": 3, "return": 1}


# --- bad arguments -----------------------------------------------------------------------------------

@pytest.mark.parametrize("argv, match", [
    (["--scenes", "default,nope"], "unknown scene 'nope'"),
    (["--presets", "drafty"], "did you mean 'draft'"),
    (["--baseline", "/nonexistent/shader.glsl"], "does not exist"),
    (["--json", "/nonexistent/dir/out.json"], "does not exist"),
    (["--json", "out.txt"], "must end in .json"),
    (["--end-to-end", "--json", "out.txt"], "must end in .json"),
    (["--ref-samples", "2000000"], "at most 1048576"),
    (["--repeats", "0"], "repeats"),
    (["--repeats", "many"], "invalid int"),
    (["--size", "12x"], "size"),
])
def test_bad_arguments_are_one_line_exit_2(argv, match, capsys):
    assert main(["bench", "--quick", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and match in err and err.startswith("sdfpbr")


def test_bad_argument_in_a_fresh_process_has_no_traceback(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "sdfpbr", "bench", "--scenes", "grid4x4"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and proc.stderr.count("\n") == 1


def test_timing_only_run_writes_json_and_no_plot(tmp_path):
    """--no-reference measures no error, so no time-error plot is drawn beside --json (it
    crashed on an empty log axis) and an explicit --plot is refused before the run."""
    out = tmp_path / "t.json"
    base = [sys.executable, "-m", "sdfpbr", "bench", "--no-reference", "--no-cold", "--scenes", "furnace",
            "--presets", "draft", "--size", "32x32", "--repeats", "1", "-q"]
    proc = subprocess.run(base + ["--json", str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    assert out.exists() and not out.with_suffix(".png").exists()
    proc = subprocess.run(base + ["--plot", str(tmp_path / "p.png")], capture_output=True, text=True)
    assert proc.returncode == 2 and "--no-reference" in proc.stderr and not (tmp_path / "p.png").exists()


def test_end_to_end_measures_each_figure_beside_its_target(session, tmp_path):
    """`bench --end-to-end` at a toy size: every figure measured (a finite value, a target and
    whether it is met; timings are reported, not asserted here), peak memory read from the
    child processes, and an animation grows the cache by no more than the one bake its first
    chart made (its later frames' bakes are not written)."""
    charts = tmp_path / "charts"
    charts.mkdir()
    (charts / "one.toml").write_text('rows = 2\ncols = 2\nsize = "64x64"\n', encoding="utf-8")
    cfg = suite.BenchConfig(width=64, height=64)
    figures = end_to_end.end_to_end_figures(session, cfg, charts, frames=3, big_size=96)
    assert len(figures) == 8, [f.name for f in figures]
    for f in figures:
        assert f.value is not None and math.isfinite(f.value) and f.target and isinstance(f.met, bool), f
    by_unit = {f.unit: f for f in figures}
    assert by_unit["GB"].value > 0 and by_unit["x one chart's"].value > 0
    assert by_unit["MB"].met, by_unit["MB"]   # the orbit's cache growth within one bake
    assert "every image rendered" in figures[3].detail and "nothing changed" in figures[4].name


def test_end_to_end_reads_a_childs_own_peak_memory_not_the_bench_process_size(tmp_path):
    """Linux starts a child's peak resident memory at what its parent held when it forked: a
    bench that holds charts would read its own size as every child's peak. 512 MB held here, a
    64 x 64 chart in a child (under 300 MB wherever it was measured) must read below it."""
    held = np.ones(64 * 2**20)   # 512 MB, every page touched
    child = end_to_end.run_process(["chart", "--size", "64x64", "-o", str(tmp_path / "c.png")])
    assert held.sum() > 0 and child.peak_bytes is not None
    assert 0 < child.peak_bytes < held.nbytes, child.peak_bytes / 2**20


def test_a_reference_is_keyed_by_the_code_it_runs(tmp_path, monkeypatch):
    """The bench keeps a reference until what the path tracer runs changes: editing a
    chart-only shader (the bounce cache), or a comment, a docstring or the spacing of what it
    runs, keeps hours of references; editing the path tracer's code renders them again. The
    oracle enters by the values of the compensation table it gives the path tracer: a table
    one ulp off is another key, the same values in a new array the same key. The preset is not
    the scene (one key for every preset); the samples and the seed are."""
    import shutil
    from sdfpbr.shading import compose
    spec = suite.scene_spec("cells", suite.BenchConfig(width=64, height=64))
    keys = {accuracy.reference_key(suite.scene_spec("cells", suite.BenchConfig(width=64, height=64), preset), 64, 0)
            for preset in suite.available_presets()}
    assert len(keys) == 1
    assert accuracy.reference_key(spec, 128, 0) not in keys and accuracy.reference_key(spec, 64, 1) not in keys
    shaders = tmp_path / "shaders"
    shutil.copytree(compose.shader_dir(), shaders)
    monkeypatch.setattr(compose, "shader_dir", lambda: shaders)
    def key():
        return accuracy.reference_key(spec, 64, 0)
    assert key() in keys
    path = shaders / "reference_path.glsl"
    path.write_text(path.read_text().replace("\n", "\n// a note /* and more */\n", 1) + "\n/* a\n block */\n\n   \n")
    assert key() in keys
    for module, kept in (("bounce_cache.glsl", True), ("reference_path.glsl", False)):
        path = shaders / module
        path.write_text(path.read_text() + "\nconst float AN_EDIT = 1.0;\n")
        assert (key() in keys) == kept, module
    monkeypatch.undo()
    assert key() in keys
    # Its Python: the integrator and its tables are keyed, its labels are not; as code.
    names = {p.name for p in accuracy.reference_code_files()}
    assert {"integrator.py", "tables.py", "__init__.py"} <= names
    assert not {"labels.py", "shading_model.py", "lobes.py"} & names
    from sdfpbr.features import reference
    table = reference.compensation_table(spec.brdf)
    for values, kept in ((table.copy(), True), (np.nextafter(table, np.float32(2.0)), False)):
        monkeypatch.setattr(reference, "compensation_table", lambda model, cache=None, sheen=False, t=values: t)
        assert (key() in keys) == kept
    monkeypatch.undo()
    copies = []
    for i, p in enumerate(accuracy.reference_code_files()):
        (tmp_path / "py" / str(i)).mkdir(parents=True)
        copies.append(Path(shutil.copy(p, tmp_path / "py" / str(i) / p.name)))
    monkeypatch.setattr(accuracy, "reference_code_files", lambda: copies)
    assert key() in keys
    integrator = next(p for p in copies if p.name == "integrator.py")
    text = integrator.read_text()
    assert text.startswith('"""')
    integrator.write_text('"""A docstring\'s edit. '
                          + text[3:].replace("annotations\n", "annotations  # a note\n\n", 1))
    assert key() in keys
    integrator.write_text(text + "\nAN_EDIT = 1\n")
    assert key() not in keys


def test_a_bigger_reference_goes_on_from_a_cached_smaller_one(session, tmp_path):
    """The bench asked for 4n samples goes on from a cached run of n (or 2n) with the same
    seed, keeps the first run's time in its own, and gives the straight run's bits; another
    seed starts from zero."""
    from sdfpbr.cache import ArrayCache
    from sdfpbr.gpu.session import Session
    from sdfpbr.features.reference import render_reference
    fresh = Session(session.ctx, ArrayCache(tmp_path / "cache"))
    spec = suite.scene_spec("cells", suite.BenchConfig(width=24, height=24))
    lines = []
    first = accuracy.get_reference(fresh, spec, 3, 0, lines.append)
    bigger = accuracy.get_reference(fresh, spec, 12, 0, lines.append)
    other = accuracy.get_reference(fresh, spec, 12, 1, lines.append)
    assert not first.cached and not bigger.cached and not other.cached
    assert "going on from the cached 3" in lines[1] and "going on" not in lines[0] + lines[2], lines
    assert bigger.seconds > first.seconds and bigger.samples == 12
    straight = render_reference(spec, samples=12, seed=0, session=session)
    assert np.array_equal(bigger.hdr, straight.hdr) and np.array_equal(bigger.image, straight.image)
    assert np.array_equal(bigger.stderr, straight.stderr, equal_nan=True)
    again = accuracy.get_reference(fresh, spec, 12, 0, lines.append)
    assert again.cached and np.array_equal(again.hdr, bigger.hdr) and len(lines) == 3
    # Not only from halves: 16 goes on from 12 (as the reference's most, 1048576, from 655360).
    most = accuracy.get_reference(fresh, spec, 16, 0, lines.append)
    assert "going on from the cached 12" in lines[3], lines
    assert np.array_equal(most.hdr, render_reference(spec, samples=16, seed=0, session=session).hdr)


def test_resumable_counts_hold_every_sixteenth_and_the_halves_below():
    counts = accuracy.resumable_counts(1048576)
    assert counts == sorted(set(counts), reverse=True) and counts[0] == 983040 and 655360 in counts
    assert all(1 <= c < 1048576 for c in counts) and {1048576 >> k for k in range(1, 21)} <= set(counts)
    assert accuracy.resumable_counts(1) == [] and accuracy.resumable_counts(12) == [9, 6, 3]


@pytest.mark.parametrize("samples, advice", [(655360, "--ref-samples 1048576 goes on from the cached 655360"),
                                             (1048576, "at the reference's most samples (1048576)")])
def test_a_noisy_references_advice_stays_within_the_references_most_samples(samples, advice):
    row = {"scene": "lobes", "preset": "high", "width": 8, "height": 8, "timing": "finish-wall-clock",
           "ref_judges": False, "ref_samples": samples}
    table = report.format_table({"rows": [row], "machine": {"gl_renderer": "llvmpipe", "cpu_count": 2}})
    assert advice in table.splitlines()[-1], table
