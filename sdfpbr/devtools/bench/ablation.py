"""Ablation: one feature off at a time on the default scene, and the "pays nothing" pairs (a
feature asked for but unusable must compose to the same source and time the same)."""
from __future__ import annotations

import re

from .report import format_row
from .suite import ABLATIONS, ABSENT_PAIRS, FEATURE_IDENTIFIERS, BenchConfig, scene_spec
from .timing import time_interleaved, timing_row, within_noise


def code_identifiers(text: str) -> dict[str, int]:
    """Identifier -> number of uses in GLSL code (comments and preprocessor lines left out)."""
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    text = "\n".join(line for line in text.splitlines() if not line.lstrip().startswith("#"))
    counts: dict[str, int] = {}
    for name in re.findall(r"\b[A-Za-z_]\w*\b", text):
        counts[name] = counts.get(name, 0) + 1
    return counts


def ablation_rows(session, cfg: BenchConfig, log) -> list[dict]:
    """One feature off at a time, then the 'absent' pairs; all timed in interleaved rounds."""
    from ...shading.plan import render_plan
    full_spec = scene_spec("default", cfg)
    variants = {f: scene_spec("default", cfg, **o) for f, o in ABLATIONS.items()}
    pairs = {name: (scene_spec("default", cfg, **a), scene_spec("default", cfg, **b))
             for name, (a, b) in ABSENT_PAIRS.items()}
    specs = [full_spec, *variants.values(), *(s for pair in pairs.values() for s in pair)]
    log(f"ablation: {len(specs)} configurations x 3 interleaved rounds of {cfg.repeats} draws ...")
    timings = iter(time_interleaved(session, specs, cfg))
    full = next(timings)
    full_ids = code_identifiers(render_plan(full_spec).chart.text)
    rows = []
    base = timing_row("default", "ablation:full", full_spec, full)
    base.update(delta_ms=0.0, ratio=1.0)
    rows.append(base)
    for feature, spec in variants.items():
        t = next(timings)
        ids = code_identifiers(render_plan(spec).chart.text)
        row = timing_row("default", f"ablation:{feature}", spec, t)
        row.update(variant=ABLATIONS[feature], delta_ms=full.draw.median_ms - t.draw.median_ms,
                   ratio=t.draw.median_ms / full.draw.median_ms,
                   removed=sorted(set(full_ids) - set(ids)), added=sorted(set(ids) - set(full_ids)))
        pattern = FEATURE_IDENTIFIERS.get(feature)
        if pattern is not None:
            # Used (named more than once) vs declared only: dead code costs nothing at run time.
            left = sorted(i for i in ids if pattern.search(i))
            row.update(leftover=[i for i in left if ids[i] > 1], dead=[i for i in left if ids[i] == 1])
            row["absent_ok"] = not row["leftover"]
        rows.append(row)
    for name, (a_spec, b_spec) in pairs.items():
        a, b = next(timings), next(timings)
        row = timing_row("default", f"absent:{name}", a_spec, a)
        same = render_plan(a_spec).chart.digest == render_plan(b_spec).chart.digest
        row.update(variant=ABSENT_PAIRS[name][0], without=ABSENT_PAIRS[name][1], without_ms=b.draw.median_ms,
                   delta_ms=a.draw.median_ms - b.draw.median_ms, ratio=a.draw.median_ms / b.draw.median_ms,
                   same_source=same, within_noise=within_noise(a.draw, b.draw), absent_ok=same)
        rows.append(row)
    for row in rows:
        log("  " + format_row(row))
    return rows
