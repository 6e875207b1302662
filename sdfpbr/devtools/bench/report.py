"""The benchmark's output: a fixed-width table, JSON and a render-time vs FLIP plot."""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np

from ...files import atomic_file, atomic_path
from .accuracy import reference_samples_cap
from .suite import available_presets


COLUMNS = (
    ("scene", "scene", "{:<12}"), ("preset", "preset", "{:<30}"), ("size", "size", "{:>9}"),
    ("spheres", "sph", "{:>4}"), ("render_ms", "render ms", "{:>10.1f}"), ("render_ms_mad", "±", "{:>6.1f}"),
    ("compile_ms", "compile ms", "{:>10.1f}"), ("source_bytes", "src kB", "{:>7.1f}"),
    ("cold_s", "cold s", "{:>7.2f}"), ("cold_warm_cache_s", "cold* s", "{:>7.2f}"), ("start_s", "start s", "{:>7.2f}"),
    ("flip_mean", "FLIP", "{:>7.4f}"), ("flip_sphere_mean", "FLIPsph", "{:>7.4f}"),
    ("rel_rmse", "relRMSE", "{:>8.4f}"), ("ref_noise_flip", "noise", "{:>7.4f}"),
    ("bias_worst", "bias%", "{:>6.2f}"), ("bias_noise", "±", "{:>5.2f}"), ("extra", "", "{}"),
)


def _cell(row: dict, key: str, fmt: str) -> str:
    width = int(re.search(r"(\d+)", fmt).group(1)) if re.search(r"\d", fmt) else 0
    if key == "size":
        v = f"{row['width']}x{row['height']}"
    elif key in ("bias_worst", "bias_noise"):
        v = 100 * row[key] if row.get(key) is not None else None
    elif key == "source_bytes":
        v = row.get(key) / 1024 if row.get(key) is not None else None
    elif key == "extra":
        bits = []
        if row.get("shader"):
            bits.append(Path(row["shader"]).name)
        if row.get("ref_judges") is False:
            bits.append("FLIP: reference too noisy to judge" + ("" if row.get("bias_judged") is not True
                                                                  else "; bias judged"))
        if row.get("settled") is False:
            bits.append("draw times not settled")
        if "ratio" in row:
            bits.append(f"x{row['ratio']:.2f}")
        if "same_source" in row:
            bits.append("same source" if row["same_source"] else "SOURCE DIFFERS")
            bits.append("within noise" if row["within_noise"] else "outside noise")
        elif "absent_ok" in row:
            bits.append("code gone" if row["absent_ok"] else "left: " + ",".join(row["leftover"][:4]))
            if row.get("dead"):
                bits.append("dead: " + ",".join(row["dead"][:4]))
        return "  ".join(bits)
    else:
        v = row.get(key)
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return f"{'-':>{width}}" if not fmt.startswith("{:<") else f"{'-':<{width}}"
    return fmt.format(v)


def format_header() -> str:
    out = []
    for key, title, fmt in COLUMNS:
        width = int(re.search(r"(\d+)", fmt).group(1)) if re.search(r"\d", fmt) else 0
        out.append(f"{title:<{width}}" if fmt.startswith("{:<") else f"{title:>{width}}")
    return " ".join(out).rstrip()


def format_row(row: dict) -> str:
    return " ".join(_cell(row, key, fmt) for key, _, fmt in COLUMNS).rstrip()


def format_table(report: dict) -> str:
    lines = [format_header()]
    lines += [format_row(r) for r in report["rows"]]
    methods = sorted({r["timing"] for r in report["rows"] if r.get("timing")})
    lines.append(f"timing: {', '.join(methods)}; {report['machine']['gl_renderer']}, "
                 f"{report['machine']['cpu_count']} CPUs")
    noisy = sorted({r["ref_samples"] for r in report["rows"] if r.get("ref_judges") is False and r.get("ref_samples")})
    if noisy:   # a bigger reference goes on from the cached one (accuracy.get_reference)
        more = min(2 * noisy[-1], reference_samples_cap() or 2 * noisy[-1])
        lines.append(f"a reference too noisy to judge: --ref-samples {more} goes on from the "
                     f"cached {noisy[-1]}-sample ones" if more > noisy[-1] else
                     f"a reference too noisy to judge at the reference's most samples ({noisy[-1]}): "
                     f"a smaller --size judges sooner")
    return "\n".join(lines)


def _json_safe(v):
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, (np.floating, np.integer)):
        return _json_safe(v.item())
    if isinstance(v, dict):
        return {k: _json_safe(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_safe(x) for x in v]
    return v


def write_json(path: str | Path, report: dict) -> None:
    data = json.dumps(_json_safe(report), indent=1, sort_keys=False).encode()
    with atomic_file(path) as f:
        f.write(data)


# Noise floors within this factor of each other share a label (two labels on one line overlap).
NOISE_LABEL_MERGE = 1.15


def plain_log_ticks(axis) -> None:
    """Ticks of a log axis as plain numbers (20, 0.05): 1, 2, 3 and 5 per decade over a short
    range, fewer over a long one, and no labelled minor ticks: matplotlib's default labels
    minor ticks in a range under a decade ("2x10^1 3x10^1 4x10^1 ..."), and they overlapped."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    lo, hi = axis.get_view_interval()
    decades = math.log10(max(hi, lo * 1.0001) / lo) if lo > 0 else 9.0
    subs = ((1.0, 2.0, 3.0, 5.0) if decades <= 1.5 else (1.0, 2.0, 5.0) if decades <= 2.5
            else (1.0, 3.0) if decades <= 4 else (1.0,))
    axis.set_major_locator(LogLocator(base=10, subs=subs))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def write_plot(path: str | Path, report: dict) -> None:
    """Render time vs mean LDR FLIP, one point per scene x preset (log-log)."""
    try:
        import matplotlib
    except ImportError:
        from ...extras import missing_extra
        raise missing_extra("metrics", "--plot", "or --no-plot") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in report["rows"] if r["preset"] in available_presets()]
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=110)
    presets = sorted({r["preset"] for r in rows}, key=lambda p: available_presets().index(p))
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    markers = "osD^vP*X"
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    plotted = False
    for r in rows:
        if r.get("flip_mean") is None or not r.get("render_ms"):
            continue
        c = colors[presets.index(r["preset"]) % len(colors)]
        m = markers[scenes.index(r["scene"]) % len(markers)]
        ax.scatter(r["render_ms"], max(r["flip_mean"], 1e-4), color=c, marker=m, s=46, zorder=3)
        ax.annotate(f"{r['scene']}/{r['preset']}", (r["render_ms"], max(r["flip_mean"], 1e-4)),
                    fontsize=7, xytext=(4, 3), textcoords="offset points")
        plotted = True
    # The time-error front: each scene's presets joined in preset order (draft, default, high;
    # seed002 stays a lone point, the baseline approach), and the reference's noise floor.
    front = [p for p in ("draft", "default", "high") if p in presets]
    for s in scenes:
        pts = [(r["render_ms"], max(r["flip_mean"], 1e-4)) for p in front for r in rows
               if r["scene"] == s and r["preset"] == p and r.get("flip_mean") is not None and r.get("render_ms")]
        if len(pts) > 1:
            ax.plot(*zip(*pts), color="0.55", lw=1, zorder=2)
    # Each scene's reference noise floor; scenes whose floors nearly meet share one label.
    floors = sorted((max(noise[0], 1e-4), s) for s in scenes
                    if (noise := [r["ref_noise_flip"] for r in rows
                                  if r["scene"] == s and r.get("ref_noise_flip") is not None]))
    groups: list[list] = []
    for level, s in floors:
        if groups and level <= groups[-1][0] * NOISE_LABEL_MERGE:
            groups[-1][1].append(s)
        else:
            groups.append([level, [s]])
        ax.axhline(level, color="0.7", ls=":", lw=1)
    for level, names in groups:
        ax.text(0.01, level, f" {', '.join(names)}: reference noise", transform=ax.get_yaxis_transform(),
                fontsize=7, va="bottom", color="0.45")
    for r in report["rows"]:
        if r["preset"] == "baseline":   # its label runs up the line, clear of the points' labels
            ax.axvline(r["render_ms"], color="0.4", ls="--", lw=1)
            ax.text(r["render_ms"], 0.02, f"baseline {Path(r.get('shader') or '').name} ",
                    transform=ax.get_xaxis_transform(), fontsize=7, rotation=90, ha="right", va="bottom", color="0.3")
    for p in presets:
        ax.scatter([], [], color=colors[presets.index(p) % len(colors)], marker="o", label=f"preset {p}")
    for s in scenes:
        ax.scatter([], [], color="0.5", marker=markers[scenes.index(s) % len(markers)], label=f"scene {s}")
    ax.set_xscale("log")
    plain_log_ticks(ax.xaxis)
    if plotted:
        ax.set_yscale("log")
        plain_log_ticks(ax.yaxis)
    else:
        ax.text(0.5, 0.5, "no error figures (no reference)", transform=ax.transAxes, ha="center")
    ax.set_xlabel("chart draw time, ms (median)")
    ax.set_ylabel("mean LDR FLIP vs reference")
    m = report["machine"]
    size = f"{rows[0]['width']}x{rows[0]['height']}" if rows else ""
    ax.set_title(f"sdfpbr bench {size} — {m['gl_renderer'].split('|')[0].strip()}, {m['cpu_count']} CPUs", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    with atomic_path(path, ".png") as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
