"""Accuracy: reference renders (cached on disk by scene, samples, seed, version and reference
code) and the error columns of a chart against its reference."""
from __future__ import annotations

import ast
import hashlib
import importlib.util
import re
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ... import __version__
from ...spec.chart_spec import ChartSpec


@dataclass
class Reference:
    hdr: np.ndarray
    image: np.ndarray
    stderr: np.ndarray
    row: np.ndarray
    col: np.ndarray
    samples: int
    seconds: float
    cached: bool


REFERENCE_MODULE = "sdfpbr.features.reference"


def reference_available() -> bool:
    return importlib.util.find_spec(REFERENCE_MODULE) is not None


def reference_samples_cap() -> int | None:
    """The most samples a pixel of the reference takes, where the reference is installed."""
    if not reference_available():
        return None
    from ...features.reference.integrator import MAX_SAMPLES
    return MAX_SAMPLES


# The Python a reference's pixels depend on besides its own package: the frame (tiles, bindings,
# display), the camera and the stage's geometry. The float64 BRDF its compensation table comes
# from (sdfpbr.oracle) enters by the table's values, not its code: an oracle edit that leaves
# the table as it was leaves the references too.
REFERENCE_DEPENDENCIES = ("sdfpbr.gpu.frame", "sdfpbr.shading.plan", "sdfpbr.shading.camera", "sdfpbr.shading.cells",
                          "sdfpbr.shading.catcher")


# The reference package's modules no pixel depends on (its labels), left out of the key.
REFERENCE_PRESENTATION = ("labels.py",)


def reference_code_files() -> list[Path]:
    """The Python a reference's pixels depend on: its package's modules but its labels, and
    REFERENCE_DEPENDENCIES."""
    found = importlib.util.find_spec(REFERENCE_MODULE)
    if found.submodule_search_locations:
        files = sorted(p for d in found.submodule_search_locations for p in Path(d).rglob("*.py")
                       if p.name not in REFERENCE_PRESENTATION)
    else:
        files = [Path(found.origin)]
    return files + [Path(importlib.util.find_spec(name).origin) for name in REFERENCE_DEPENDENCIES]


_GLSL_COMMENT = re.compile(r"/\*.*?\*/|//[^\n]*", re.S)


def glsl_code(text: str) -> str:
    """GLSL as the compiler runs it: comments out, each line's spacing collapsed, blank lines
    and #line directives (the composer's, which name lines for error messages) dropped."""
    lines = (" ".join(line.split()) for line in _GLSL_COMMENT.sub(" ", text).splitlines())
    return "\n".join(line for line in lines if line and not line.startswith("#line"))


def python_code(text: str) -> str:
    """Python as the interpreter runs it: its syntax tree, without comments, layout or
    docstrings."""
    tree = ast.parse(text)
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and body
                and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)):
            node.body = body[1:] or [ast.Pass()]
    return ast.dump(tree)


def _reference_code_digest(spec: ChartSpec, cache=None) -> str:
    """The reference's code for this spec: reference_code_files and the programs its plan
    composes, as code, and the values of the compensation table it reads (so an edit of a
    chart-only shader, of the reference's labels, of a comment or of the oracle beside the
    table leaves the bench's references alone, and any edit of what the path tracer runs or
    reads re-renders them). ``cache``: where the table is kept (else computed)."""
    from ...shading.plan import reference_plan
    from ...features.reference import compensation_choice, compensation_table
    h = hashlib.sha256()
    for p in reference_code_files():
        h.update(p.name.encode())
        h.update(python_code(p.read_text(encoding="utf-8")).encode())
    plan = reference_plan(spec)
    for source in plan.sources():
        h.update(glsl_code(source.text).encode())
    h.update(np.ascontiguousarray(compensation_table(cache=cache, **compensation_choice(spec, plan))).tobytes())
    return h.hexdigest()


def reference_key(spec: ChartSpec, samples: int, seed: int, cache=None) -> str:
    return _key(spec, samples, seed, _reference_code_digest(spec, cache))


def _key(spec: ChartSpec, samples: int, seed: int, code_digest: str) -> str:
    from ...cache import content_key
    from ...features.reference import scene_fields
    return content_key("bench-reference", scene_fields(spec), samples, seed, __version__, code_digest)


def get_reference(session, spec: ChartSpec, samples: int, seed: int, log=None) -> Reference:
    """The reference of ``spec`` at ``samples`` per pixel and ``seed``: from the cache, else
    rendered, going on from the cached run of the same seed with the most samples among
    resumable_counts(samples) when there is one; ``seconds`` is the render time of all its samples."""
    from ...features.reference import render_reference
    code_digest = _reference_code_digest(spec, session.cache)
    key = _key(spec, samples, seed, code_digest)
    cached = session.cache.get("bench-reference", key, require_finite=False)   # stderr may be NaN
    if cached is not None:
        return Reference(cached["hdr"], cached["image"], cached["stderr"], cached["row"], cached["col"],
                         int(cached["samples"]), float(cached["seconds"]), True)
    resume, before = _resumable(session, spec, samples, seed, code_digest)
    if log:
        log(f"reference: {spec.rows}x{spec.cols} {spec.width}x{spec.height}, {samples} samples/pixel"
            + (f", going on from the cached {resume.samples}" if resume else "") + " ...")
    start = time.perf_counter()
    ref = render_reference(spec, samples=samples, seed=seed, session=session, resume=resume)
    seconds = before + time.perf_counter() - start
    aov = ref.aov
    out = Reference(np.asarray(ref.hdr, np.float32), np.asarray(ref.image, np.uint8),
                    np.asarray(ref.stderr, np.float32), np.asarray(aov["row"]), np.asarray(aov["col"]),
                    int(np.max(ref.samples)), seconds, False)
    state = ref.accumulators
    extra = {} if state.catcher is None else {"catcher": state.catcher}
    session.cache.put("bench-reference", key, {"hdr": out.hdr, "image": out.image, "stderr": out.stderr,
                                                "row": out.row, "col": out.col, "samples": np.array(out.samples),
                                                "seconds": np.array(seconds), "sums": state.sums,
                                                "moments": state.moments, **extra})
    return out


def resumable_counts(samples: int) -> list[int]:
    """The smaller sample counts a cached run of the same seed may hold, most first: samples
    k / 16 (k = 15 .. 1, where whole: a doubling's half, and 655360 under the reference's most,
    1048576), then samples / 32, / 64, ..."""
    counts = [samples * k // 16 for k in range(15, 0, -1) if samples * k % 16 == 0]
    fewer = samples // 32
    while fewer >= 1:
        counts.append(fewer)
        fewer //= 2
    return sorted({c for c in counts if 1 <= c < samples}, reverse=True)


def _resumable(session, spec: ChartSpec, samples: int, seed: int, code_digest: str):
    """(accumulators, their render seconds) of the cached reference of ``spec`` and ``seed``
    with the most samples among resumable_counts(samples) that kept its accumulators, else
    (None, 0.0). A reference's samples are hashes of (seed, pixel, sample index), so going on
    from one gives the straight run's bits."""
    from ...features.reference import Accumulators, run_key
    for fewer in resumable_counts(samples):
        cached = session.cache.get("bench-reference", _key(spec, fewer, seed, code_digest), require_finite=False)
        if cached is not None and "sums" in cached:
            state = Accumulators(cached["sums"], cached["moments"], cached.get("catcher"), fewer, run_key(spec, seed))
            return state, float(cached["seconds"])
    return None, 0.0


# A reference judges a figure only if its own noise is well below it: the FLIP between two
# references that differ only in their seed must be at least this factor under the chart's.
NOISE_MARGIN = 3.0


def noise_floor(a: Reference, b: Reference) -> float:
    """Mean LDR FLIP between two references of one scene with different seeds: the error figure
    a perfect chart would still get from the reference's own noise."""
    from ...image import metrics
    return metrics.flip_ldr(a.image, b.image)[0]


def cell_luminance(hdr: np.ndarray, ref: Reference, spec: ChartSpec) -> np.ndarray:
    """(rows, cols) mean Rec. 709 luminance of each sphere's pixels (the reference's AOVs)."""
    from ...image import metrics
    from ...image.colour import luminance
    lum = luminance(np.asarray(hdr, np.float64)[..., :3])
    return metrics.per_cell_mean(lum, ref.row, ref.col, spec.rows, spec.cols)


def cell_bias_columns(result, ref: Reference, other: Reference, spec: ChartSpec) -> dict:
    """The chart's error as its spheres' mean luminance over the reference's, minus 1: the worst
    cell's |bias|, and the two-seed noise of those means (over the
    cells' root mean square of |a - b| / mean). Region means converge far faster than per-pixel
    FLIP, so a small reference judges them: ``bias_judged`` when the noise is at most
    NOISE_MARGIN times under the figure."""
    a, b = cell_luminance(ref.hdr, ref, spec), cell_luminance(other.hdr, ref, spec)
    mean = 0.5 * (a + b)
    ok = np.isfinite(mean) & (mean > 0)
    if not ok.any():
        return {}
    chart = cell_luminance(result.hdr, ref, spec)
    bias = np.where(ok, chart / np.where(ok, mean, 1.0) - 1.0, np.nan)
    noise = float(np.sqrt(np.mean(((a - b)[ok] / mean[ok]) ** 2)))
    worst = float(np.nanmax(np.abs(bias)))
    return {"bias_cells": bias.tolist(), "bias_worst": worst, "bias_noise": noise,
            "bias_judged": bool(worst >= NOISE_MARGIN * noise)}


def error_columns(result, ref: Reference, spec: ChartSpec, heatmap_path: Path | None = None,
                  heatmap_title: str = "", noise: float | None = None, other: Reference | None = None) -> dict:
    """Error of a chart render against its reference; ``noise``: the reference's noise floor
    (noise_floor), reported beside the figures with whether the reference can judge them;
    ``other``: the reference of another seed, for the cells' bias and its noise."""
    from ...image import metrics
    mask = (ref.row >= 0) & (ref.col >= 0)
    flip_mean, flip_map = metrics.flip_ldr(result.image, ref.image)
    hdr_flip, _ = metrics.flip_hdr(np.maximum(result.hdr, 0.0), np.maximum(ref.hdr, 0.0))
    cols = {
        "flip_mean": flip_mean,
        "flip_sphere_mean": float(flip_map[mask].mean()) if mask.any() else None,
        "hdr_flip_mean": hdr_flip,
        "rel_rmse": metrics.rel_rmse(result.hdr, ref.hdr, mask=mask if mask.any() else None),
        "flip_cells": metrics.per_cell_mean(flip_map, ref.row, ref.col, spec.rows, spec.cols).tolist(),
        "rel_rmse_cells": metrics.per_cell_rel_rmse(result.hdr, ref.hdr, ref.row, ref.col,
                                                    spec.rows, spec.cols).tolist(),
        "ref_samples": ref.samples,
        "ref_seconds": ref.seconds,
    }
    if noise is not None:
        cols["ref_noise_flip"] = noise
        cols["ref_judges"] = bool(flip_mean >= NOISE_MARGIN * noise)
    if other is not None:
        cols.update(cell_bias_columns(result, ref, other, spec))
    # The reference's own noise: its mean standard error and the rel RMSE that noise alone gives.
    err = ref.stderr if ref.stderr.ndim == 3 else ref.stderr[..., None]
    if err.shape[:2] == ref.hdr.shape[:2] and mask.any():
        e2 = (err.astype(np.float64) ** 2 / (ref.hdr.astype(np.float64) ** 2 + metrics.DEFAULT_EPS)).mean(axis=2)
        cols["ref_stderr"] = float(err[mask].mean())
        cols["ref_rel_noise"] = float(np.sqrt(e2[mask].mean()))
    if heatmap_path is not None:
        from ...image.io import write_png
        # A fixed 0..1 scale, FLIP's own range, so heat maps of different presets compare.
        title = f"LDR FLIP vs reference: {heatmap_title}  (mean {flip_mean:.4f}, {ref.samples} spp reference)"
        write_png(heatmap_path, metrics.heatmap_image(flip_map, title=title, vmin=0.0, vmax=1.0))
    return cols
