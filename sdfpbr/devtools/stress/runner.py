"""Running a sweep: one GL session per backend, each configuration rendered and checked, a crash
in one configuration recorded as its failure."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ...oracle.furnace import FurnaceTable
from ...progress import Progress
from .cases import TILED_TILE, Case, Outcome
from .checks import (DISPLAY_LSB, check_finite, display_error, furnace_error, isolated_outliers,
                     monotonic_error, tiles_equal)
from .report import Report, write_failure


def run_case(case: Case, sessions: dict, table: FurnaceTable) -> Outcome:
    start = time.perf_counter()
    spec = case.spec
    result = sessions[case.backend].render(spec, aovs=case.aovs)
    failures = check_finite(result.hdr, result.alpha)
    metrics = {}
    lsb, bad = display_error(result.hdr, result.alpha, result.image, spec)
    metrics["display_lsb"] = lsb
    if bad:
        failures.append(f"{bad} display pixels differ from the tone-mapped HDR "
                        f"by more than {DISPLAY_LSB} LSB (worst {lsb})")
    ratio, flagged, tested = isolated_outliers(result.hdr, result.aov, spec, result.camera)
    metrics["firefly_ratio"] = ratio
    metrics["firefly_tested"] = tested
    if flagged:
        failures.append(f"{flagged} isolated firefly pixels (worst {ratio:.3g}x the brightest neighbour)")
    grazing = result.aov["ndotv"][result.aov["row"] >= 0] if case.aovs else np.empty(0)
    metrics["min_ndotv"] = float(grazing.min()) if grazing.size else 1.0
    if case.kind == "furnace":
        err, bad, tested = furnace_error(result.hdr, result.aov, spec, table)
        metrics["furnace_err"] = err
        metrics["furnace_tested"] = tested
        if bad:
            failures.append(f"{bad} furnace pixels off the float64 expectation (worst relative {err:.3g})")
    if case.kind == "monotonic":
        fails, rise, mirror_err = monotonic_error(result.hdr, result.aov, spec, case.probe, result.camera)
        metrics["monotonic_rise"] = rise
        metrics["mirror_err"] = mirror_err
        failures += fails
    if case.backend == "egl-tiled":
        if not tiles_equal(result, sessions["egl"].render(spec, aovs=case.aovs)):
            failures.append(f"a render in {TILED_TILE}-pixel tiles differs from the untiled render")
    return Outcome(case, failures, metrics, time.perf_counter() - start)


def make_sessions(cases: list[Case], cache=None) -> tuple[dict, list[str]]:
    """One session per backend the cases use (plus a small-tile EGL one); backends that cannot
    start are reported, and their cases skipped."""
    from ...errors import GLUnavailable
    from ...gpu.gl import create_context
    from ...gpu.session import Session
    sessions, notes = {}, []
    for name in sorted({c.backend for c in cases}
                       | ({"egl"} if any(c.backend == "egl-tiled" for c in cases) else set())):
        base = name.split("-")[0]
        try:
            ctx = sessions[base].ctx if base in sessions else create_context(base)
        except GLUnavailable as exc:
            notes.append(f"backend {name} skipped: {exc}")
            continue
        sessions[name] = Session(ctx, cache, tile=TILED_TILE if name == "egl-tiled" else None)
    return sessions, notes


def run_sweep(cases: list[Case], sessions: dict, notes: list, seed: int = 0,
              failures_dir: Path | None = None, progress: bool = True) -> Report:
    table = FurnaceTable()
    runnable = [c for c in cases if c.backend in sessions]
    # Cases that share a program run together (the sessions cache every program anyway; this
    # keeps the working set small and the compile spikes at family boundaries).
    from ...shading.plan import render_plan
    runnable.sort(key=lambda c: (c.backend, render_plan(c.spec).chart.digest, c.index))
    start = time.perf_counter()
    outcomes, failing = [], 0
    with Progress(len(runnable), "stress", "configurations", enabled=progress) as bar:
        for case in runnable:
            try:
                outcome = run_case(case, sessions, table)
            except Exception as exc:   # a crash in one configuration is a failure, not the end
                outcome = Outcome(case, [f"render raised {type(exc).__name__}: "
                                         f"{str(exc).splitlines()[0] if str(exc) else ''}"])
            outcomes.append(outcome)
            failing += bool(outcome.failures)
            if outcome.failures and failures_dir is not None:
                write_failure(failures_dir, outcome)
            bar.update(1, f"{failing} failing" if failing else "")
    outcomes.sort(key=lambda o: o.case.index)
    return Report(outcomes, notes, time.perf_counter() - start, seed)
