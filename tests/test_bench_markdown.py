"""The benchmark report made from `sdfpbr bench --json` output (sdfpbr.devtools.bench.markdown):
its numbers are the JSON's, its command lines rebuild the run, --check tells a stale report."""
import json
import subprocess
import sys

import pytest

from sdfpbr.devtools.bench import markdown
from sdfpbr.devtools.bench.suite import BenchConfig

MACHINE = {"gl_renderer": "llvmpipe (test)", "cpu_count": 2, "python": "3.11.7", "sdfpbr": "0.1.0"}


def _row(scene, preset, render_ms, flip, cells=None, **extra):
    return {"scene": scene, "preset": preset, "width": 64, "height": 64, "spheres": 25,
            "render_ms": render_ms, "render_ms_mad": 0.5, "settled": True, "compile_ms": 100.0,
            "source_bytes": 2048, "cold_s": None, "cold_warm_cache_s": None, "start_s": None,
            "flip_mean": flip, "flip_sphere_mean": flip, "rel_rmse": 0.05, "ref_noise_flip": 0.004,
            "ref_samples": 1024, "ref_judges": flip >= 3 * 0.004,
            "flip_cells": cells or [[flip] * 5 for _ in range(5)], **extra}


def _report():
    worst = [[0.01] * 5 for _ in range(5)]
    worst[4][3] = 0.25            # metallic 1, roughness 0.75 on the default chart
    rows = [_row("default", "draft", 3.25, 0.0412), _row("default", "default", 6.5, 0.0231, worst),
            _row("default", "seed002", 9.0, 0.3321)]
    settings = {**{k: v for k, v in vars(BenchConfig()).items() if k != "log"},
                "scenes": ["default"], "presets": ["draft", "default", "seed002"], "width": 64, "height": 64,
                "ref_samples": 1024, "cold": False}
    return {"machine": MACHINE, "settings": settings, "rows": rows}


def test_report_holds_the_json_numbers_and_its_command():
    text = markdown.report_markdown([_report()], ["docs/bench/run.json"], lambda name: f"fig/{name}.png")
    assert text.startswith("# Benchmarks\n")
    # Every preset's figure, as the JSON has it, in the preset table and the accuracy table.
    for flip in ("0.0412", "0.0231", "0.3321"):
        assert text.count(flip) >= 2
    # The worst sphere, named by its material (row 5 = metallic 1, column 4 = roughness 0.75).
    assert "| `default` | `default` | metallic 1, roughness 0.75 | 0.2500 |" in text
    # The command that made the JSON, rebuilt from its settings.
    assert ("sdfpbr bench --size 64x64 --scenes default --presets draft,default,seed002 "
            "--ref-samples 1024 --no-cold --json docs/bench/run.json") in text
    assert "![" in text and "fig/plot.png" in text and "fig/cells.png" in text
    # No path leads outside the repository.
    assert "../" not in text


def test_page_variant_leaves_the_title_to_the_page():
    text = markdown.report_markdown([_report()], ["docs/bench/run.json"], str, title=False, figures=[])
    assert not text.startswith("#") and "\n## Choosing a preset\n" in text and "![" not in text


@pytest.mark.requires_extra("matplotlib")   # the figures
def test_cli_writes_then_checks(tmp_path):
    src = tmp_path / "run.json"
    src.write_text(json.dumps(_report()))
    out = tmp_path / "BENCH.md"
    cmd = [sys.executable, "-m", "sdfpbr.devtools.bench.markdown", str(src), "-o", str(out),
           "--figures", str(tmp_path / "figs")]
    subprocess.run(cmd, check=True, capture_output=True)
    assert (tmp_path / "figs" / markdown.FIGURES["plot"]).stat().st_size > 1000
    assert subprocess.run(cmd + ["--check"], check=False, capture_output=True).returncode == 0
    out.write_text(out.read_text().replace("0.0231", "0.0230"))       # a hand edit
    stale = subprocess.run(cmd + ["--check"], check=False, capture_output=True, text=True)
    assert stale.returncode == 1 and "is not what" in stale.stderr


def test_not_a_bench_file_is_one_line_and_status_2(tmp_path):
    bad = tmp_path / "x.json"
    bad.write_text('{"rows": []}')
    proc = subprocess.run([sys.executable, "-m", "sdfpbr.devtools.bench.markdown", str(bad), "-o",
                           str(tmp_path / "o.md"), "--check"], check=False, capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "not `sdfpbr bench --json` output" in proc.stderr
