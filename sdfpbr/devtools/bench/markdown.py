"""The benchmark report in Markdown, made from ``sdfpbr bench --json`` output: BENCHMARKS.md and
the docs' accuracy-and-speed page are both this module's text.

    python -m sdfpbr.devtools.bench.markdown docs/bench/*.json -o BENCHMARKS.md --figures docs
    python -m sdfpbr.devtools.bench.markdown docs/bench/*.json -o BENCHMARKS.md --check

The first writes the report and its figures (the time-error plot and the per-sphere error maps,
``bench-*.png`` in ``--figures``); ``--check`` exits 1 when the report is not what the JSON
gives. Every number in the report comes from the JSON; earlier reports live in git's history.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Callable
from pathlib import Path

from ...errors import SpecError
from .suite import SCENE_NOTES, available_presets

# What each preset is for: the words beside its numbers in "Choosing a preset".
PRESET_NOTES = {
    "draft": "previews: one environment read along the reflection, one ray for the floor's bounce",
    "default": "everyday use: a fitted two-read environment lookup, five rays for the floor's bounce",
    "high": "figures for print: the environment integrated per pixel (256 samples), 4 points per edge pixel",
    "seed002": "the baseline approach (a Shadertoy-style raymarcher), kept to compare against, not for use",
}
FIGURES = {"plot": "bench-time-error.png", "cells": "bench-cells.png"}
WORST_CELLS = 8          # rows of the worst-cells table


def load_report(path: str | Path) -> dict:
    """One ``sdfpbr bench --json`` file; one line and SpecError when it is not one."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise SpecError(f"cannot read {path}: {exc.strerror or exc}") from None
    except ValueError as exc:
        raise SpecError(f"{path} is not JSON: {exc}") from None
    if not isinstance(data, dict) or "machine" not in data or not ({"rows", "end_to_end", "summary"} & set(data)):
        raise SpecError(f"{path} is not `sdfpbr bench --json` output (no machine and rows)")
    return data


# ---- numbers -----------------------------------------------------------------------------------

def _num(v, digits: int) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f"{v:.{digits}f}"


def _ms(v) -> str:
    if v is None:
        return "–"
    return f"{v:.0f}" if v >= 100 else f"{v:.1f}"


def _size(row: dict) -> str:
    return f"{row['width']}×{row['height']}"


def _suite_rows(report: dict) -> list[dict]:
    """The rows of the fixed scene suite at the presets (no ablation or baseline rows)."""
    return [r for r in report.get("rows", [])
            if r.get("scene") in SCENE_NOTES and r.get("preset") in available_presets()]


def _other_rows(report: dict) -> list[dict]:
    return [r for r in report.get("rows", []) if r not in _suite_rows(report)]


def _accuracy(reports: list[dict]) -> list[dict]:
    """The suite's error rows (a peer run's rows are reported in its own section)."""
    return [r for rep in reports if not rep.get("peer") for r in _suite_rows(rep) if r.get("flip_mean") is not None]


def _speed(reports: list[dict]) -> list[dict]:
    """Timed suite rows from the reports at the largest size (the speed figures)."""
    rows = [r for rep in reports if not rep.get("peer") for r in _suite_rows(rep) if r.get("render_ms")]
    if not rows:
        return []
    biggest = max(r["width"] * r["height"] for r in rows)
    return [r for r in rows if r["width"] * r["height"] == biggest]


def _table(header: list[str], rows: list[list[str]], right: int = 2) -> str:
    """A Markdown table; columns from ``right`` on are numbers, aligned right."""
    align = ["---" if i < right else "---:" for i in range(len(header))]
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join(align) + " |"]
    lines += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in rows]
    return "\n".join(lines)


# ---- commands ----------------------------------------------------------------------------------

def bench_command(report: dict, json_path: str) -> str:
    """The ``sdfpbr bench`` command line a report's settings come from."""
    from .suite import SCENES, BenchConfig
    s = report.get("settings", {})
    if "summary" in report:
        return _random_command(s)
    d = BenchConfig()
    out = ["sdfpbr bench"]
    if "end_to_end" in report:
        out.append("--end-to-end")
    if (s.get("width"), s.get("height")) != (d.width, d.height) and s.get("width"):
        out.append(f"--size {s['width']}x{s['height']}")
    if s.get("scenes") and tuple(s["scenes"]) != tuple(SCENES) and "end_to_end" not in report:
        out.append("--scenes " + ",".join(s["scenes"]))
    if s.get("presets") and tuple(s["presets"]) != available_presets() and "end_to_end" not in report:
        out.append("--presets " + ",".join(s["presets"]))
    for key, flag in (("repeats", "--repeats"), ("warmup", "--warmup"), ("seed", "--seed")):
        if key in s and s[key] != getattr(d, key):
            out.append(f"{flag} {s[key]}")
    if s.get("reference") is False:
        out.append("--no-reference")
    elif "ref_samples" in s and s["ref_samples"] != d.ref_samples and "end_to_end" not in report:
        out.append(f"--ref-samples {s['ref_samples']}")
    if s.get("cold") is False and "end_to_end" not in report:
        out.append("--no-cold")
    if s.get("ablation"):
        out.append("--ablation")
    if report.get("peer"):
        peer = report["peer"]
        out.append(f"--peer {peer['peer']}")
        samples = {sc.get("peer_samples") for sc in peer.get("scenes", []) if sc.get("comparable")}
        if len(samples) == 1 and samples != {s.get("ref_samples")}:
            out.append(f"--peer-samples {samples.pop()}")
    out.append(f"--json {json_path}")
    return " ".join(out)


def _columns_help() -> str:
    """The column glossary of ``sdfpbr bench --help``, as the command prints it."""
    from ...cli.commands.bench import EPILOG
    text = EPILOG.split("scenes:")[0]
    return text.replace("columns:\n", "", 1).rstrip()


# ---- figures -----------------------------------------------------------------------------------

def write_figures(reports: list[dict], out_dir: str | Path, names: dict[str, str] = FIGURES) -> dict[str, Path]:
    """The report's figures in ``out_dir``: the time-error plot of the accuracy report and the
    per-sphere error maps. Returns {figure: path} for those the reports can make."""
    from .report import write_plot
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    made = {name: out_dir / names[name] for name in figures_of(reports)}
    if "plot" in made:   # the plot shows one run: the first with error figures
        first = next(rep for rep in reports if _accuracy([rep]))
        write_plot(made["plot"], {**first, "rows": _accuracy([first])})
    if "cells" in made:
        _write_cell_maps(made["cells"], _cell_rows(reports))
    return made


def _cell_rows(reports: list[dict]) -> list[dict]:
    """The rows the per-sphere maps show: the presets for use (seed002's errors, ten times
    theirs, would leave them black on a shared scale)."""
    from .suite import BASE_PRESETS
    return [r for r in _accuracy(reports) if r.get("flip_cells") and r["preset"] in BASE_PRESETS]


def figures_of(reports: list[dict]) -> list[str]:
    """The figures (keys of FIGURES) the reports have the numbers for."""
    accuracy = _accuracy(reports)
    return [name for name, has in (("plot", bool(accuracy)), ("cells", bool(_cell_rows(reports)))) if has]


def _write_cell_maps(path: Path, rows: list[dict]) -> None:
    """Each scene x preset's mean FLIP per sphere, one small map each, on one colour scale."""
    try:
        import matplotlib
    except ImportError:
        from ...extras import missing_extra
        raise missing_extra("metrics", "the report's figures") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ...files import atomic_path
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    presets = [p for p in available_presets() if any(r["preset"] == p for r in rows)]
    top = max(max(max(c) for c in r["flip_cells"]) for r in rows)
    fig, axes = plt.subplots(len(scenes), len(presets), figsize=(2.2 * len(presets) + 1.4, 2.3 * len(scenes) + 0.4),
                             dpi=100, squeeze=False)
    image = None
    for i, scene in enumerate(scenes):
        for j, preset in enumerate(presets):
            ax = axes[i][j]
            ax.set_xticks([])
            ax.set_yticks([])
            row = next((r for r in rows if r["scene"] == scene and r["preset"] == preset), None)
            if row is None:
                ax.set_axis_off()
                continue
            grid = np.array(row["flip_cells"], dtype=float)
            image = ax.imshow(grid, cmap="magma", vmin=0.0, vmax=top)
            worst = np.unravel_index(np.nanargmax(grid), grid.shape)
            ax.add_patch(plt.Rectangle((worst[1] - 0.5, worst[0] - 0.5), 1, 1, fill=False, ec="#39d", lw=2))
            if i == 0:
                ax.set_title(preset, fontsize=10)
            if j == 0:
                ax.set_ylabel(scene, fontsize=10)
            ax.set_xlabel(f"mean {row['flip_mean']:.4f}\nworst sphere {grid.max():.3f}", fontsize=8)
    if image is not None:
        fig.colorbar(image, ax=axes, shrink=0.8, label="mean LDR FLIP of the sphere's cell")
    with atomic_path(path, ".png") as tmp:
        fig.savefig(tmp, format="png", bbox_inches="tight")
    plt.close(fig)


# ---- the report --------------------------------------------------------------------------------

def report_markdown(reports: list[dict], sources: list[str], link: Callable[[str], str],
                    title: bool = True, figures: dict | None = None) -> str:
    """The report as Markdown. ``sources``: the JSON files as the text names them (beside
    ``reports``); ``link(figure)``: the path a figure is shown from; ``figures``: those made
    (default: figures_of(reports)); ``title``: the report's own title (a page that has one
    leaves it out; the sections are second-level headings either way)."""
    s = "##"
    figures = figures_of(reports) if figures is None else figures
    accuracy, speed = _accuracy(reports), _speed(reports)
    out: list[str] = []
    if title:
        out.append("# Benchmarks\n")
    regenerate = ("python -m sdfpbr.devtools.bench.markdown " + " ".join(sources)
                  + " -o BENCHMARKS.md --figures docs")
    if title:
        out.append("The chart's speed and its error against the path-traced reference of the same scene, "
                   "made from committed `sdfpbr bench --json` output by `" + regenerate + "`. "
                   "Do not edit it by hand; earlier reports are in this file's git history.\n")
    else:
        out.append(f"Made from {', '.join(f'`{x}`' for x in sources)} by `{regenerate}`.\n")

    out.append(f"{s} Choosing a preset\n")
    out.append(_preset_table(accuracy, speed) + "\n")
    out.append("Use `default`. Use `high` for figures where the smoothest spheres' reflections and "
               "the floor in front of them matter, and `draft` for previews. FLIP is the mean LDR FLIP "
               "of the whole image against the reference (0: the same image, 1: as different as can be).\n")

    if accuracy:
        size = _size(accuracy[0])
        out.append(f"{s} Accuracy at {size}\n")
        out.append(_accuracy_table(accuracy) + "\n")
        out.append("*noise* is the FLIP between two references that differ only in their random seed: "
                   "the figure a perfect chart would still get. A figure under three times the noise "
                   "is not *judged*: the reference cannot tell it apart from its own noise, so the "
                   "true error is smaller than it reads.\n")
        if "plot" in figures:
            out.append(f"![render time against error, one point per scene and preset]({link('plot')})\n")
        if "cells" in figures:
            out.append("The error of every sphere (roughness across, the scene's other axis down), each "
                       "scene and preset on one colour scale, the worst sphere framed in blue "
                       "(`seed002` left out: its errors are ten times these):\n")
            out.append(f"![mean FLIP per sphere, each scene and preset]({link('cells')})\n")
        out.append(_worst_cells(accuracy) + "\n")

    if speed:
        out.append(f"{s} Speed at {_size(speed[0])}\n")
        out.append(_speed_table(speed) + "\n")

    for report, source in zip(reports, sources):
        if "summary" in report:
            out.append(_random_section(report, source, s))
    peers = [(report, source) for report, source in zip(reports, sources) if report.get("peer")]
    for report, source in peers:
        out.append(_peer_section(report["peer"], source, s))
    other = [r for rep in reports if not rep.get("peer") for r in _other_rows(rep)]
    if other:   # rows of scenes outside the fixed suite, listed as they come
        out.append(f"{s} Other rows\n")
        out.append(_table(["scene", "preset", "size", "draw ms", "FLIP"],
                          [[r.get("scene", "?"), r.get("preset", "?"), _size(r) if "width" in r else "–",
                            _ms(r.get("render_ms")), _num(r.get("flip_mean"), 4)] for r in other]) + "\n")

    out.append(f"{s} How these were measured\n")
    for report, source in zip(reports, sources):
        m = report["machine"]
        out.append(f"- `{source}`: {m.get('gl_renderer', '?')}, {m.get('cpu_count', '?')} CPU cores, "
                   f"Python {m.get('python', '?')}, sdfpbr {m.get('sdfpbr', '?')}.\n"
                   f"  `{bench_command(report, source)}`")
    out.append("")
    scenes = list(dict.fromkeys(r["scene"] for r in accuracy + speed))
    if scenes:
        out.append("Scenes (`sdfpbr bench --help`):\n")
        out.append("\n".join(f"- `{name}`: {SCENE_NOTES[name]}" for name in scenes) + "\n")
    out.append("Columns (`sdfpbr bench --help`):\n\n```text\n" + _columns_help() + "\n```\n")
    return "\n".join(out).rstrip() + "\n"


def _pct(v) -> str:
    return "–" if v is None else f"{100 * v:.1f} %"


def _random_command(s: dict) -> str:
    from .random_suite import RandomConfig
    d = RandomConfig()
    out = [f"sdfpbr bench --random {s.get('count', '?')} --seed {s.get('seed', '?')}"]
    if s.get("size") and tuple(s["size"]) != d.size:
        out.append(f"--size {s['size'][0]}x{s['size'][1]}")
    if s.get("presets") and tuple(s["presets"]) != d.presets:
        out.append("--presets " + ",".join(s["presets"]))
    if s.get("stage", d.stage) != d.stage:
        out.append(f"--random-stage {s['stage']}")
    if s.get("ref_samples", d.ref_samples) != d.ref_samples:
        out.append(f"--ref-samples {s['ref_samples']}")
    return " ".join(out)


def _random_section(report: dict, source: str, s: str) -> str:
    """The random-scene suite: the distribution over scenes of each preset's largest region
    bias and of its FLIP, the targets beside them, the regions' 95th percentiles, the worst."""
    from .random_suite import REGIONS
    settings, summary = report["settings"], report["summary"]
    size = "×".join(str(v) for v in settings["size"])
    out = [f"{s} Random scenes: {len(report['scenes'])} scenes, {settings.get('stage', 'cells')} stage, {size}\n",
           "Scenes drawn from what users chart (`sdfpbr.devtools.bench.random_suite` documents the "
           "distribution), one sphere on its floor each. Per scene and preset, each region's *bias* is its "
           "mean luminance over the reference's, minus 1; a scene's figure is its largest |bias| over the "
           "regions its reference can judge (two seeds that differ by at most a third of the figure)."
           + ("" if report.get("complete", True) else " **This run stopped before its last scene.**") + "\n"]
    rows = []
    for p, v in summary.items():
        t = v.get("targets")
        met = v.get("met", {})
        rows.append([f"`{p}`", _pct(v["bias_median"]), _pct(v["bias_p95"]), _pct(v["bias_worst"]),
                     f"{100 * t['bias_p95']:.0f} % / {100 * t['bias_worst']:.0f} %" if t else "–",
                     ("yes" if met.get("bias_p95") and met.get("bias_worst") else "no") if t else "–",
                     f"{v['scenes_judged']} of {v['scenes']}"])
    out.append(_table(["preset", "median", "95th", "worst", "target 95th / worst", "met", "scenes judged"], rows,
                      right=1) + "\n")
    rows = []
    for p, v in summary.items():
        t = v.get("targets")
        rows.append([f"`{p}`", _num(v["flip_median"], 4), _num(v["flip_p95"], 4), _num(v["flip_worst"], 4),
                     f"{v['flip_judged_mean']:.4f} ({v['flip_judged_scenes']})" if v["flip_judged_mean"] else "–",
                     f"{t['flip']:.3f}" if t else "–"])
    out.append("Mean LDR FLIP over the scenes; *judged*: the mean over the scenes whose reference noise is at most "
               "a third of the figure (their count), against the target over at least 8 such scenes:\n")
    out.append(_table(["preset", "median", "95th", "worst", "judged mean", "target"], rows, right=1) + "\n")
    out.append("The 95th percentile of |bias| per region (where the error is):\n")
    regions = [k for k in REGIONS if any(v["per_region_p95"].get(k) is not None for v in summary.values())]
    out.append(_table(["preset", *[k.replace("_", " ") for k in regions]],
                      [[f"`{p}`", *[_pct(v["per_region_p95"].get(k)) for k in regions]] for p, v in summary.items()],
                      right=1) + "\n")
    worst = [f"- `{p}`: {w['scene']}, {w['region'].replace('_', ' ')} {100 * w['bias']:+.1f} %, FLIP "
             f"{w['flip']:.4f} ({w['summary']})" for p, v in summary.items() if (w := v.get("worst_scene"))]
    if worst:
        out.append("The worst scene at each preset (`--heatmaps DIR` writes its FLIP and bias maps):\n")
        out.append("\n".join(worst) + "\n")
    out.append(f"`{_random_command(settings)}` (`{source}`).\n")
    return "\n".join(out)


def _peer_section(peer: dict, source: str, s: str) -> str:
    """The peer renderer: the reference checked region by region, and each preset's time to
    equal error."""
    out = [f"{s} The reference against an independent path tracer\n",
           f"Mitsuba {peer['version']} ({peer['variant']}, {peer['threads']} threads) renders the same scenes with a "
           "glTF BSDF written in the project from the specification (`sdfpbr bench --peer mitsuba`). A region "
           f"agrees when the two renderers differ by at most {peer['noise_sigmas']:g} sigma of their two seeds' "
           "noise.\n"]
    rows, ratios = [], []
    for sc in peer["scenes"]:
        if not sc["comparable"]:
            rows.append([f"`{sc['scene']}`", "not comparable: " + sc["reason"], "–", "–", "–"])
            continue
        worst = max(sc["regions"].items(), key=lambda kv: abs(kv[1]["z"]))
        rows.append([f"`{sc['scene']}`", "yes" if sc["agrees"] else "**no**", worst[0].replace("_", " "),
                     f"{100 * worst[1]['rel_diff']:+.2f} %", f"{worst[1]['z']:+.2f}"])
        for r in sc.get("presets", []):
            note = ("reference too noisy" if r.get("ref_judges") is False else "") + \
                   ("; extrapolated" if r.get("extrapolated") else "")
            ratios.append([f"`{sc['scene']}`", f"`{r['preset']}`", _num(r["flip_mean"], 4), _ms(r["render_ms"]),
                           "–" if r["peer_samples"] is None else f"{r['peer_samples']:.3g}",
                           "–" if r["peer_seconds"] is None else f"{r['peer_seconds']:.3g}",
                           "–" if r["ratio"] is None else f"{r['ratio']:.3g}", note or "–"])
    out.append(_table(["scene", "agrees", "worst region", "difference", "z"], rows, right=3) + "\n")
    if ratios:
        out.append("Time to equal error: the peer's samples and seconds to reach each preset's FLIP against the "
                   "converged reference, and their ratio to the preset's draw:\n")
        out.append(_table(["scene", "preset", "FLIP", "draw ms", "peer spp", "peer s", "ratio", "note"], ratios) + "\n")
    out.append(f"From `{source}`.\n")
    return "\n".join(out)


def _by(rows: list[dict], scene: str, preset: str) -> dict | None:
    return next((r for r in rows if r["scene"] == scene and r["preset"] == preset), None)


def _preset_table(accuracy: list[dict], speed: list[dict]) -> str:
    presets = [p for p in available_presets() if any(r["preset"] == p for r in accuracy + speed)]
    acc_scene = ("default" if any(r["scene"] == "default" for r in accuracy)
                 else (accuracy[0]["scene"] if accuracy else ""))
    speed_scene = "default" if any(r["scene"] == "default" for r in speed) else (speed[0]["scene"] if speed else "")
    starts = any(r.get("start_s") is not None for r in speed)
    header = ["preset", "for"]
    if speed:
        header += [f"draw ms, {speed_scene} {_size(speed[0])}"] + (["start s"] if starts else [])
    if accuracy:
        header += [f"FLIP, {acc_scene} {_size(accuracy[0])}", "FLIP, every scene (mean)"]
    rows = []
    for p in presets:
        row = [f"`{p}`", PRESET_NOTES.get(p, "")]
        if speed:
            r = _by(speed, speed_scene, p)
            row += [_ms(r and r.get("render_ms"))] + ([_num(r and r.get("start_s"), 2)] if starts else [])
        if accuracy:
            r = _by(accuracy, acc_scene, p)
            flips = [x["flip_mean"] for x in accuracy if x["preset"] == p]
            row += [_num(r and r.get("flip_mean"), 4), _num(sum(flips) / len(flips) if flips else None, 4)]
        rows.append(row)
    return _table(header, rows)


def _accuracy_table(rows: list[dict]) -> str:
    out = []
    for r in rows:
        judged = r.get("ref_judges")
        out.append([f"`{r['scene']}`", f"`{r['preset']}`", _ms(r.get("render_ms")), _num(r.get("flip_mean"), 4),
                    _num(r.get("flip_sphere_mean"), 4), _num(r.get("rel_rmse"), 4), _num(r.get("ref_noise_flip"), 4),
                    f"{r.get('ref_samples', '–')}", "yes" if judged else ("no" if judged is False else "–")])
    return _table(["scene", "preset", "draw ms", "FLIP", "FLIP, spheres", "relRMSE", "noise", "reference spp",
                   "judged"], out)


def _worst_cells(rows: list[dict]) -> str:
    cells = []
    for r in rows:
        for i, line in enumerate(r.get("flip_cells") or []):
            for j, v in enumerate(line):
                if v is not None and math.isfinite(v):
                    cells.append((v, r["scene"], r["preset"], i + 1, j + 1))
    cells.sort(reverse=True)
    presets = [p for p in ("default", "high") if any(c[2] == p for c in cells)]
    worst = [c for c in cells if c[2] in presets][:WORST_CELLS]
    if not worst:
        return ""
    size = {(r["scene"], r["preset"]): (r["width"], r["height"]) for r in rows}
    text = f"The {len(worst)} worst spheres at {' and '.join(f'`{p}`' for p in presets)}:\n\n"
    return text + _table(["scene", "preset", "sphere", "FLIP"], right=3, rows=
                         [[f"`{c[1]}`", f"`{c[2]}`", _sphere(c[1], c[2], size[c[1], c[2]], c[3] - 1, c[4] - 1),
                           f"{c[0]:.4f}"] for c in worst])


def _sphere(scene: str, preset: str, size: tuple[int, int], row: int, col: int) -> str:
    """A sphere of a suite scene by its material: 'metallic 1, roughness 0.75'."""
    from ...spec.material import axis_values
    from .suite import BenchConfig, scene_spec
    spec = scene_spec(scene, BenchConfig(width=size[0], height=size[1]), preset)
    y, x = axis_values(spec, "y")[row], axis_values(spec, "x")[col]
    return f"{spec.y_axis.replace('_', ' ')} {y:.3g}, {spec.x_axis.replace('_', ' ')} {x:.3g}"


def _speed_table(rows: list[dict]) -> str:
    out = []
    for r in rows:
        mad = r.get("render_ms_mad")
        draw = _ms(r.get("render_ms")) + (f" ± {_ms(mad)}" if mad is not None else "")
        if r.get("settled") is False:
            draw += " (not settled)"
        src = r.get("source_bytes")
        out.append([f"`{r['scene']}`", f"`{r['preset']}`", draw, _ms(r.get("compile_ms")),
                    _num(src / 1024 if src else None, 1), _num(r.get("cold_s"), 2),
                    _num(r.get("cold_warm_cache_s"), 2), _num(r.get("start_s"), 2)])
    return _table(["scene", "preset", "draw ms", "compile ms", "source kB", "cold s", "cold* s", "start s"], out)


# ---- command line ------------------------------------------------------------------------------

def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m sdfpbr.devtools.bench.markdown",
                                description="Write the benchmark report (BENCHMARKS.md) "
                                            "from `sdfpbr bench --json` files.")
    p.add_argument("json", nargs="+", help="sdfpbr bench --json output files")
    p.add_argument("-o", "--output", default="BENCHMARKS.md", help="the report (default BENCHMARKS.md)")
    p.add_argument("--figures", metavar="DIR", default="docs",
                   help="where the figures go, as bench-*.png (default docs)")
    p.add_argument("--check", action="store_true",
                   help="write nothing; exit 1 when the report is not what the JSON gives")
    args = p.parse_args(argv)
    try:
        reports = [load_report(path) for path in args.json]
    except SpecError as exc:
        print(f"sdfpbr: {exc}", file=sys.stderr)
        return 2
    out = Path(args.output)
    fig_dir = Path(args.figures)
    figures = {k: fig_dir / FIGURES[k] for k in figures_of(reports)}
    made = figures if args.check else write_figures(reports, fig_dir)

    def link(name: str) -> str:
        return Path(os.path.relpath(figures[name], out.parent)).as_posix()
    sources = [Path(os.path.relpath(path, out.parent)).as_posix() for path in args.json]
    text = report_markdown(reports, sources, link, figures=made)
    if args.check:
        old = out.read_text(encoding="utf-8") if out.is_file() else ""
        if old != text:
            print(f"{out} is not what {' '.join(args.json)} give: run {p.prog} "
                  f"{' '.join(args.json)} -o {out} --figures {fig_dir}", file=sys.stderr)
            return 1
        return 0
    from ...files import write_bytes
    write_bytes(out, text.encode("utf-8"))
    print(f"{out}: {len(text.encode('utf-8')) / 1024:.1f} kB; figures: "
          + ", ".join(str(path) for path in made.values()), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
