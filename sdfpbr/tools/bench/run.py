"""The speed/error benchmark behind ``sdfpbr bench``.

For every scene of a fixed suite and every quality preset it measures

* ``render_ms``: the chart program's draw at the full resolution, median of ``repeats`` draws
  after ``warmup`` draws. On hardware drivers a GL timer query times each draw; Mesa's
  software rasterizers (llvmpipe) answer timer queries with the time to *queue* the draw, not
  to run it, so there each draw is bracketed by ``ctx.finish()`` and timed on the wall clock. The timed draw is checked against the renderer's
  own output (``draw_check``), so what is timed is what the chart shows.
* ``compile_ms``: link of a fresh program (a nonce comment defeats every shader cache) plus
  its first draw on a small target of the chart's formats, where llvmpipe JIT-compiles.
* ``source_bytes``: the composed chart source.
* ``cold_s``: wall time of a fresh ``python -m sdfpbr chart`` process with Mesa's shader cache
  disabled and an empty sdfpbr disk cache (IBL bakes and LUTs recomputed); ``cold_warm_cache_s``:
  the same right after, with the sdfpbr disk cache filled (the user's second run).
* error against the reference renderer (``sdfpbr.reference``): mean LDR FLIP of the display
  images over the whole frame (``flip_mean``) and over sphere pixels (``flip_sphere_mean``),
  HDR FLIP, and relative RMSE of linear radiance over sphere pixels (``rel_rmse``). References
  are rendered once per scene (the scene's truth does not depend on the preset) and cached on
  disk, keyed by the scene, sample count, seed, sdfpbr version and the reference code.
"""
from __future__ import annotations

import hashlib
import importlib.util
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import SdfpbrError, SpecError
from ..spec.chart_spec import QUALITY_PRESETS, ChartSpec, make_spec

# The scene suite. Each scene is a set of spec overrides on the default chart.
SCENES: dict[str, dict] = {
    "default": {},                                    # 5x5, studio env, key + fill light, ground
    "grid3x3": {"rows": 3, "cols": 3},
    "grid10x10": {"rows": 10, "cols": 10},
    "bare": {"ground": False, "shadows": False, "ao": False},
    # White furnace: white spheres in a uniform environment, nothing else. An energy-conserving
    # BRDF leaves every sphere at the background's radiance, so any error left is the
    # IBL/BRDF integration (split sum, DFG LUT, multiple-scattering compensation).
    "furnace": {"env": "uniform", "lights": "none", "ground": False, "shadows": False, "ao": False,
                "base_color": (1.0, 1.0, 1.0)},
}
SCENE_NOTES = {
    "default": "the default 5x5 chart",
    "grid3x3": "3x3 spheres",
    "grid10x10": "10x10 spheres",
    "bare": "no ground, shadows or AO",
    "furnace": "white spheres, uniform env, no lights/ground (white furnace)",
}
BASE_PRESETS = ("draft", "default", "high")

# Ablation: one feature off at a time on the default scene (preset "default"). The spec has one
# IBL switch (diffuse and specular IBL go together).
ABLATIONS: dict[str, dict] = {
    "shadows": {"shadows": False},
    "ao": {"ao": False},
    "ibl": {"ibl": False},
    "lights": {"lights": "none"},
    "ground": {"ground": False},
    "spp4": {"spp": 4},                # the cost of 4 samples per pixel over 1
    "march": {"intersect": "march"},   # sphere tracing instead of the analytic ray-sphere hit
}
# Identifiers (code, not comments) that belong to a feature: none may remain without it.
FEATURE_IDENTIFIERS = {
    "shadows": re.compile(r"shadow"),
    "ao": re.compile(r"occlusion|(^|_)ao(_|$)"),
    "ibl": re.compile(r"prefilter|irradiance|(^|_)sh(_|$)|(^|_)ibl(_|$)"),
    "lights": re.compile(r"(dir|point)_light"),
    "ground": re.compile(r"(^|_)ground"),
}
# "Pays nothing": a feature the scene asks for but cannot use must cost nothing. Each pair is
# (asks for it, leaves it out); both should compose to the same source and time the same.
ABSENT_PAIRS: dict[str, tuple[dict, dict]] = {
    "shadows-without-ground": ({"ground": False, "shadows": True}, {"ground": False, "shadows": False}),
    "shadows-without-lights": ({"lights": "none", "shadows": True}, {"lights": "none", "shadows": False}),
    "ao-without-ibl": ({"ibl": False, "ao": True}, {"ibl": False, "ao": False}),
}

REQUIRED_KEYS = ("scene", "preset", "render_ms", "compile_ms", "cold_s", "flip_mean", "rel_rmse")


def available_presets() -> tuple[str, ...]:
    return BASE_PRESETS + tuple(p for p in ("seed002",) if p in QUALITY_PRESETS)


@dataclass
class BenchConfig:
    scenes: tuple[str, ...] = tuple(SCENES)
    presets: tuple[str, ...] = field(default_factory=available_presets)
    width: int = 1024
    height: int = 1024
    repeats: int = 5
    warmup: int = 1
    ref_samples: int = 256
    seed: int = 0
    reference: bool = True
    cold: bool = True
    ablation: bool = False
    baseline: str | None = None
    backend: str = "auto"
    heatmaps: str | None = None      # directory for FLIP heat maps, one per scene x preset
    log: object = None               # a callable taking one progress line, or None

    @classmethod
    def quick(cls, **overrides) -> "BenchConfig":
        """CI-sized: 256^2, two scenes, two presets, 3 repeats, 16-sample references."""
        base = dict(scenes=("default", "bare"), presets=("draft", "default"), width=256, height=256,
                    repeats=3, warmup=1, ref_samples=16)
        base.update(overrides)
        return cls(**base)


def _choices(values, allowed, what: str) -> tuple[str, ...]:
    import difflib
    out = []
    for v in values:
        if v not in allowed:
            close = difflib.get_close_matches(v, list(allowed), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise SpecError(f"unknown {what} {v!r}{hint}; allowed: {', '.join(allowed)}")
        if v not in out:
            out.append(v)
    if not out:
        raise SpecError(f"no {what} selected; allowed: {', '.join(allowed)}")
    return tuple(out)


def check_config(cfg: BenchConfig) -> BenchConfig:
    cfg.scenes = _choices(cfg.scenes, tuple(SCENES), "scene")
    cfg.presets = _choices(cfg.presets, available_presets(), "preset")
    for name, lo in (("repeats", 1), ("warmup", 0), ("ref_samples", 1)):
        v = getattr(cfg, name)
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise SpecError(f"--{name.replace('_', '-')} must be a whole number >= {lo}, got {v!r}")
    make_spec(width=cfg.width, height=cfg.height, backend=cfg.backend)   # validates the size
    if cfg.baseline is not None:
        from .baseline import load_shadertoy
        load_shadertoy(cfg.baseline)      # a bad path or a document without GLSL fails now
    if cfg.heatmaps is not None:
        p = Path(cfg.heatmaps)
        if p.exists() and not p.is_dir():
            raise SpecError(f"--heatmaps {p} exists and is not a directory")
        if not (p if p.exists() else p.parent if str(p.parent) else Path(".")).is_dir():
            raise SpecError(f"--heatmaps {p}: directory {p.parent} does not exist")
    return cfg


def scene_spec(scene: str, cfg: BenchConfig, preset: str = "default", **extra) -> ChartSpec:
    return make_spec(width=cfg.width, height=cfg.height, backend=cfg.backend, quality=preset,
                     **{**SCENES[scene], **extra})


# ---------------------------------------------------------------------------------------------
# Timing.

@dataclass
class DrawTiming:
    median_ms: float
    min_ms: float
    mad_ms: float          # median absolute deviation: the noise of this measurement
    method: str            # "gl-timer-query" or "finish-wall-clock"
    samples_ms: list


_SOFTWARE_RASTERIZERS = ("llvmpipe", "softpipe", "swrast", "lavapipe")


def timer_query_measures_execution(ctx) -> bool:
    """Mesa's software rasterizers answer GL_TIME_ELAPSED with the time to queue a draw (a few
    ms for a 60 ms draw), not to run it; hardware drivers time the execution."""
    renderer = str(ctx.info.get("GL_RENDERER", "")).lower()
    return not any(name in renderer for name in _SOFTWARE_RASTERIZERS)


def time_draws(ctx, draw, repeats: int, warmup: int = 1) -> DrawTiming:
    """Median draw time: a GL timer query where it measures execution (hardware), else the wall
    clock between ctx.finish() calls. One method per context, so rows compare."""
    for _ in range(warmup):
        draw()
    ctx.finish()
    query = None
    if timer_query_measures_execution(ctx):
        try:
            query = ctx.query(time=True)
        except Exception:   # a context without timer queries
            query = None
    samples = []
    for _ in range(repeats):
        ctx.finish()
        start = time.perf_counter()
        if query is not None:
            with query:
                draw()
        else:
            draw()
        ctx.finish()
        wall = (time.perf_counter() - start) * 1e3
        samples.append(query.elapsed / 1e6 if query is not None and query.elapsed > 0 else wall)
    method = "gl-timer-query" if query is not None else "finish-wall-clock"
    med = statistics.median(samples)
    mad = statistics.median(abs(s - med) for s in samples)
    return DrawTiming(med, min(samples), mad, method, [round(s, 3) for s in samples])


def within_noise(a: DrawTiming, b: DrawTiming) -> bool:
    """Two medians agree within 3 MADs of either run plus 3 % (the machine is shared)."""
    return abs(a.median_ms - b.median_ms) <= 3.0 * max(a.mad_ms, b.mad_ms) + 0.03 * max(a.median_ms, b.median_ms)


def _tiles(width: int, height: int):
    from ..gpu.render import TILE
    for y0 in range(0, height, TILE):
        for x0 in range(0, width, TILE):
            yield x0, y0, min(TILE, width - x0), min(TILE, height - y0)


def time_compile(ctx, vertex: str, fragment: str, formats: list[tuple[int, str]]) -> tuple[float, float]:
    """(link ms, first-draw ms) of a program that no cache has seen. llvmpipe compiles the
    machine code of a fragment shader at its first draw, so that draw is part of compiling."""
    import moderngl
    fragment = fragment + f"\n// sdfpbr bench nonce {uuid.uuid4().hex}\n"
    start = time.perf_counter()
    program = ctx.program(vertex_shader=vertex, fragment_shader=fragment)
    link = (time.perf_counter() - start) * 1e3
    targets = [ctx.texture((16, 16), comps, dtype=dtype) for comps, dtype in formats]
    fbo = ctx.framebuffer(color_attachments=targets)
    vao = ctx.vertex_array(program, [])
    fbo.use()
    ctx.finish()
    start = time.perf_counter()
    vao.render(moderngl.TRIANGLES, vertices=3)
    ctx.finish()
    first = (time.perf_counter() - start) * 1e3
    for obj in (vao, fbo, *targets, program):
        obj.release()
    return link, first


@dataclass
class ChartTiming:
    result: object         # the RenderResult of the warm-up render
    draw: DrawTiming
    link_ms: float
    first_draw_ms: float
    source_bytes: int
    draw_check: float      # max |timed draw - render| / max radiance; ~0 when they agree


def time_chart(renderer, spec: ChartSpec, repeats: int, warmup: int, compile_time: bool = True) -> ChartTiming:
    """Render once (programs, IBL, uniforms, bound textures), then time the chart program's draw
    alone into the same float targets the renderer uses."""
    import moderngl
    from ..shading.compose import compose
    from ..gpu.render import chart_source
    result = renderer.render(spec)
    ctx = renderer.ctx
    source = chart_source(spec)
    with ctx:
        program = renderer.programs.fragment(source)
        W, H = spec.width, spec.height
        passes = []
        for x0, y0, tw, th in _tiles(W, H):
            targets = [ctx.texture((tw, th), 4, dtype="f4") for _ in range(3)]
            passes.append((x0, y0, tw, th, targets, ctx.framebuffer(color_attachments=targets)))
        vao = ctx.vertex_array(program, [])

        def draw():
            for x0, y0, _, _, _, fbo in passes:
                fbo.use()
                if "u_tile_origin" in program:
                    program["u_tile_origin"].value = (x0, y0)
                vao.render(moderngl.TRIANGLES, vertices=3)

        timing = time_draws(ctx, draw, repeats, warmup)
        radiance = np.empty((H, W, 3), np.float32)
        for x0, y0, tw, th, targets, _ in passes:
            tile = np.frombuffer(targets[0].read(), np.float32).reshape(th, tw, 4)[::-1, :, :3]
            radiance[H - y0 - th:H - y0, x0:x0 + tw] = tile
        scale = max(float(np.abs(result.hdr).max()), 1e-6)
        check = float(np.abs(radiance - result.hdr).max()) / scale
        vao.release()
        for *_, targets, fbo in passes:
            fbo.release()
            for t in targets:
                t.release()
        link = first = math.nan
        if compile_time:
            link, first = time_compile(ctx, compose("fullscreen_vert.glsl").text, source.text, [(4, "f4")] * 3)
    return ChartTiming(result, timing, link, first, len(source.text.encode()), check)


# ---------------------------------------------------------------------------------------------
# Cold processes.

def cli_flags(overrides: dict, preset: str, width: int, height: int, backend: str) -> list[str]:
    """`sdfpbr chart` flags for a scene's overrides."""
    flags = ["--size", f"{width}x{height}", "--quality", preset]
    if backend != "auto":
        flags += ["--backend", backend]
    switches = {"shadows": "--no-shadows", "ao": "--no-ao", "ground": "--no-ground", "ibl": "--no-ibl"}
    for key, value in overrides.items():
        if key in switches:
            if value is False:
                flags.append(switches[key])
        elif key in ("rows", "cols", "env", "lights", "spp", "intersect"):
            flags += [f"--{key}", str(value)]
        elif key == "base_color":
            flags += ["--base-color", ",".join(f"{c:g}" for c in value)]
        else:
            raise SdfpbrError(f"bench: no `sdfpbr chart` flag for scene option {key!r}")
    return flags


def cold_chart_seconds(flags: list[str], cache_dir: str, workdir: str) -> float:
    """Wall time of a fresh `python -m sdfpbr chart` with Mesa's shader cache off."""
    env = dict(os.environ, MESA_SHADER_CACHE_DISABLE="true", SDFPBR_CACHE_DIR=cache_dir)
    cmd = [sys.executable, "-m", "sdfpbr", "chart", "-o", os.path.join(workdir, "chart.png"), *flags]
    start = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["no message"])[-1]
        raise SdfpbrError(f"bench: cold `sdfpbr chart {' '.join(flags)}` failed: {last}")
    return seconds


def cold_times(overrides: dict, preset: str, cfg: BenchConfig) -> tuple[float, float]:
    """(empty sdfpbr cache, filled sdfpbr cache) seconds, both with Mesa's cache off."""
    flags = cli_flags(overrides, preset, cfg.width, cfg.height, cfg.backend)
    with tempfile.TemporaryDirectory(prefix="sdfpbr-bench-") as tmp:
        cache = os.path.join(tmp, "cache")
        cold = cold_chart_seconds(flags, cache, tmp)
        warm = cold_chart_seconds(flags, cache, tmp)
    return cold, warm


# ---------------------------------------------------------------------------------------------
# Reference renders, cached.

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


def reference_available() -> bool:
    return importlib.util.find_spec("sdfpbr.tools.reference") is not None


def _reference_code_digest() -> str:
    """The reference's code: its module and every shader (a change re-renders references)."""
    from ..shading.compose import shader_dir
    h = hashlib.sha256()
    h.update(Path(__file__).with_name("reference.py").read_bytes())
    for p in sorted(Path(str(shader_dir())).glob("*.glsl")):
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def reference_key(spec: ChartSpec, samples: int, seed: int) -> str:
    from ..cache import content_key
    d = spec.to_dict()
    for k in ("quality", "backend", "device_index", "labels", "title"):
        d.pop(k, None)
    return content_key("bench-reference", d, samples, seed, __version__, _reference_code_digest())


def get_reference(renderer, spec: ChartSpec, samples: int, seed: int, log=None) -> Reference:
    from .reference import render_reference
    key = reference_key(spec, samples, seed)
    cached = renderer.cache.get("bench-reference", key)
    if cached is not None:
        return Reference(cached["hdr"], cached["image"], cached["stderr"], cached["row"], cached["col"],
                         int(cached["samples"]), float(cached["seconds"]), True)
    if log:
        log(f"reference: {spec.rows}x{spec.cols} {spec.width}x{spec.height}, {samples} samples/pixel ...")
    start = time.perf_counter()
    ref = render_reference(spec, samples=samples, seed=seed, renderer=renderer)
    seconds = time.perf_counter() - start
    aov = ref.aov
    out = Reference(np.asarray(ref.hdr, np.float32), np.asarray(ref.image, np.uint8),
                    np.asarray(ref.stderr, np.float32), np.asarray(aov["row"]), np.asarray(aov["col"]),
                    int(np.max(ref.samples)), seconds, False)
    renderer.cache.put("bench-reference", key, {"hdr": out.hdr, "image": out.image, "stderr": out.stderr,
                                                "row": out.row, "col": out.col, "samples": np.array(out.samples),
                                                "seconds": np.array(seconds)})
    return out


def error_columns(result, ref: Reference, spec: ChartSpec, heatmap_path: Path | None = None,
                  heatmap_title: str = "") -> dict:
    from ..image import metrics
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
    # The reference's own noise: its mean standard error and the rel RMSE that noise alone gives.
    err = ref.stderr if ref.stderr.ndim == 3 else ref.stderr[..., None]
    if err.shape[:2] == ref.hdr.shape[:2] and mask.any():
        e2 = (err.astype(np.float64) ** 2 / (ref.hdr.astype(np.float64) ** 2 + metrics.DEFAULT_EPS)).mean(axis=2)
        cols["ref_stderr"] = float(err[mask].mean())
        cols["ref_rel_noise"] = float(np.sqrt(e2[mask].mean()))
    if heatmap_path is not None:
        from ..image.io import write_png
        # A fixed 0..1 scale, FLIP's own range, so heat maps of different presets compare.
        title = f"LDR FLIP vs reference: {heatmap_title}  (mean {flip_mean:.4f}, {ref.samples} spp reference)"
        write_png(heatmap_path, metrics.heatmap_image(flip_map, title=title, vmin=0.0, vmax=1.0))
    return cols


# ---------------------------------------------------------------------------------------------
# Rows.

def _row(scene: str, preset: str, spec: ChartSpec, t: ChartTiming) -> dict:
    return {
        "scene": scene, "preset": preset, "width": spec.width, "height": spec.height,
        "spheres": spec.rows * spec.cols,
        "render_ms": t.draw.median_ms, "render_ms_min": t.draw.min_ms, "render_ms_mad": t.draw.mad_ms,
        "render_samples_ms": t.draw.samples_ms, "timing": t.draw.method,
        "compile_ms": t.link_ms + t.first_draw_ms, "link_ms": t.link_ms, "first_draw_ms": t.first_draw_ms,
        "source_bytes": t.source_bytes, "draw_check": t.draw_check,
        "cold_s": None, "cold_warm_cache_s": None,
        "flip_mean": None, "flip_sphere_mean": None, "hdr_flip_mean": None, "rel_rmse": None,
    }


def run_bench(cfg: BenchConfig) -> dict:
    """Run the benchmark; returns {"machine": ..., "settings": ..., "rows": [...]}."""
    from ..api import get_renderer
    from ..gpu.gl import renderer_string
    check_config(cfg)
    log = cfg.log or (lambda line: None)
    renderer = get_renderer(cfg.backend, 0)
    rows: list[dict] = []
    use_reference = cfg.reference and reference_available()
    if cfg.reference and not use_reference:
        log("note: sdfpbr.reference is not installed; error columns stay empty")
    heat_dir = Path(cfg.heatmaps) if cfg.heatmaps else None
    if heat_dir is not None:
        heat_dir.mkdir(parents=True, exist_ok=True)

    for scene in cfg.scenes:
        ref = None
        if use_reference:
            ref = get_reference(renderer, scene_spec(scene, cfg), cfg.ref_samples, cfg.seed, log)
        for preset in cfg.presets:
            spec = scene_spec(scene, cfg, preset)
            log(f"{scene} / {preset}: timing {cfg.repeats} draws at {spec.width}x{spec.height} ...")
            t = time_chart(renderer, spec, cfg.repeats, cfg.warmup)
            row = _row(scene, preset, spec, t)
            if cfg.cold:
                row["cold_s"], row["cold_warm_cache_s"] = cold_times(SCENES[scene], preset, cfg)
            if ref is not None:
                path = heat_dir / f"flip_{scene}_{preset}.png" if heat_dir else None
                row.update(error_columns(t.result, ref, spec, path, f"{scene} / {preset}"))
            rows.append(row)
            log("  " + format_row(row))

    if cfg.baseline:
        rows.append(baseline_row(renderer, cfg))
        log("  " + format_row(rows[-1]))
    if cfg.ablation:
        rows += ablation_rows(renderer, cfg, log)

    machine = {"gl_renderer": renderer_string(renderer.ctx), "cpu_count": os.cpu_count(),
               "python": sys.version.split()[0], "sdfpbr": __version__}
    settings = {k: v for k, v in vars(cfg).items() if k != "log"}
    return {"machine": machine, "settings": settings, "rows": rows}


def baseline_row(renderer, cfg: BenchConfig) -> dict:
    """Time a Shadertoy-style shader at the bench resolution, the same way as the chart."""
    import moderngl
    from .baseline import VERTEX_SHADER, build_program, load_shadertoy, set_shadertoy_uniforms
    src = load_shadertoy(cfg.baseline)
    ctx = renderer.ctx
    W, H = cfg.width, cfg.height
    with ctx:
        program = build_program(ctx, src)
        set_shadertoy_uniforms(program, W, H)
        target = ctx.texture((W, H), 4)
        fbo = ctx.framebuffer(color_attachments=[target])
        vao = ctx.vertex_array(program, [])

        def draw():
            fbo.use()
            vao.render(moderngl.TRIANGLES, vertices=3)

        timing = time_draws(ctx, draw, cfg.repeats, cfg.warmup)
        for obj in (vao, fbo, target, program):
            obj.release()
        link, first = time_compile(ctx, VERTEX_SHADER, src.text, [(4, "f1")])
    return {
        "scene": "shadertoy", "preset": "baseline", "shader": src.origin, "entry_point": src.entry, "width": W, "height": H, "spheres": None,
        "render_ms": timing.median_ms, "render_ms_min": timing.min_ms, "render_ms_mad": timing.mad_ms,
        "render_samples_ms": timing.samples_ms, "timing": timing.method,
        "compile_ms": link + first, "link_ms": link, "first_draw_ms": first,
        "source_bytes": len(src.code.encode()), "cold_s": None, "cold_warm_cache_s": None,
        "flip_mean": None, "rel_rmse": None,
        "note": "the shader's own scene, camera and lights at iTime=0: timing only, "
                "an error against our reference would not be meaningful",
    }


# ---------------------------------------------------------------------------------------------
# Ablation.

def code_identifiers(text: str) -> dict[str, int]:
    """Identifier -> number of uses in GLSL code (comments and preprocessor lines left out)."""
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    text = "\n".join(line for line in text.splitlines() if not line.lstrip().startswith("#"))
    counts: dict[str, int] = {}
    for name in re.findall(r"\b[A-Za-z_]\w*\b", text):
        counts[name] = counts.get(name, 0) + 1
    return counts


def time_interleaved(renderer, specs: list[ChartSpec], cfg: BenchConfig, rounds: int = 3) -> list[ChartTiming]:
    """Time several specs in alternating rounds (A B C A B C ...), so a load change on the
    shared machine hits all of them alike; each draw timing is the median over every round's
    samples. Compile times come from the first round."""
    first: list[ChartTiming] = []
    samples: list[list[float]] = [[] for _ in specs]
    for r in range(rounds):
        for i, spec in enumerate(specs):
            t = time_chart(renderer, spec, cfg.repeats, cfg.warmup, compile_time=(r == 0))
            samples[i] += t.draw.samples_ms
            if r == 0:
                first.append(t)
    out = []
    for t, s in zip(first, samples):
        med = statistics.median(s)
        t.draw = DrawTiming(med, min(s), statistics.median(abs(x - med) for x in s), t.draw.method, s)
        out.append(t)
    return out


def ablation_rows(renderer, cfg: BenchConfig, log) -> list[dict]:
    """One feature off at a time, then the 'absent' pairs; all timed in interleaved rounds."""
    from ..gpu.render import chart_source
    full_spec = scene_spec("default", cfg)
    variants = {f: scene_spec("default", cfg, **o) for f, o in ABLATIONS.items()}
    pairs = {name: (scene_spec("default", cfg, **a), scene_spec("default", cfg, **b))
             for name, (a, b) in ABSENT_PAIRS.items()}
    specs = [full_spec, *variants.values(), *(s for pair in pairs.values() for s in pair)]
    log(f"ablation: {len(specs)} configurations x 3 interleaved rounds of {cfg.repeats} draws ...")
    timings = iter(time_interleaved(renderer, specs, cfg))
    full = next(timings)
    full_ids = code_identifiers(chart_source(full_spec).text)
    rows = []
    base = _row("default", "ablation:full", full_spec, full)
    base.update(delta_ms=0.0, ratio=1.0)
    rows.append(base)
    for feature, spec in variants.items():
        t = next(timings)
        ids = code_identifiers(chart_source(spec).text)
        row = _row("default", f"ablation:{feature}", spec, t)
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
        row = _row("default", f"absent:{name}", a_spec, a)
        same = chart_source(a_spec).digest == chart_source(b_spec).digest
        row.update(variant=ABSENT_PAIRS[name][0], without=ABSENT_PAIRS[name][1], without_ms=b.draw.median_ms,
                   delta_ms=a.draw.median_ms - b.draw.median_ms, ratio=a.draw.median_ms / b.draw.median_ms,
                   same_source=same, within_noise=within_noise(a.draw, b.draw), absent_ok=same)
        rows.append(row)
    for row in rows:
        log("  " + format_row(row))
    return rows


# ---------------------------------------------------------------------------------------------
# Output.

COLUMNS = (
    ("scene", "scene", "{:<12}"), ("preset", "preset", "{:<30}"), ("size", "size", "{:>9}"),
    ("spheres", "sph", "{:>4}"), ("render_ms", "render ms", "{:>10.1f}"), ("render_ms_mad", "±", "{:>6.1f}"),
    ("compile_ms", "compile ms", "{:>10.1f}"), ("source_bytes", "src kB", "{:>7.1f}"),
    ("cold_s", "cold s", "{:>7.2f}"), ("cold_warm_cache_s", "cold* s", "{:>7.2f}"),
    ("flip_mean", "FLIP", "{:>7.4f}"), ("flip_sphere_mean", "FLIPsph", "{:>7.4f}"),
    ("rel_rmse", "relRMSE", "{:>8.4f}"), ("extra", "", "{}"),
)


def _cell(row: dict, key: str, fmt: str) -> str:
    width = int(re.search(r"(\d+)", fmt).group(1)) if re.search(r"\d", fmt) else 0
    if key == "size":
        v = f"{row['width']}x{row['height']}"
    elif key == "source_bytes":
        v = row.get(key) / 1024 if row.get(key) is not None else None
    elif key == "extra":
        bits = []
        if row.get("shader"):
            bits.append(Path(row["shader"]).name)
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
    from ..image.io import atomic_file
    data = json.dumps(_json_safe(report), indent=1, sort_keys=False).encode()
    with atomic_file(path) as f:
        f.write(data)


def write_plot(path: str | Path, report: dict) -> None:
    """Render time vs mean LDR FLIP, one point per scene x preset (log-log)."""
    try:
        import matplotlib
    except ImportError:
        raise SdfpbrError("--plot needs matplotlib: pip install 'sdfpbr[metrics]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from ..image.io import atomic_path

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
    for r in report["rows"]:
        if r["preset"] == "baseline":
            ax.axvline(r["render_ms"], color="0.4", ls="--", lw=1)
            ax.text(r["render_ms"], 0.98, f" baseline {Path(r.get('shader') or '').name}", transform=ax.get_xaxis_transform(),
                    fontsize=7, va="top", color="0.3")
    for p in presets:
        ax.scatter([], [], color=colors[presets.index(p) % len(colors)], marker="o", label=f"preset {p}")
    for s in scenes:
        ax.scatter([], [], color="0.5", marker=markers[scenes.index(s) % len(markers)], label=f"scene {s}")
    ax.set_xscale("log")
    if plotted:
        ax.set_yscale("log")
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
