"""The benchmark: every scene x preset timed (and, with references, measured for error), plus
the optional baseline shader and ablation rows."""
from __future__ import annotations

import os
import sys
from pathlib import Path

from ... import __version__
from .ablation import ablation_rows
from .accuracy import error_columns, get_reference, noise_floor, reference_available
from .cold import COLD_COLUMNS, cold_times
from .report import format_row
from .suite import BenchConfig, check_config, scene_overrides, scene_spec
from .timing import time_chart, time_compile, time_draws, timing_row


def run_bench(cfg: BenchConfig) -> dict:
    """Run the benchmark; returns {"machine": ..., "settings": ..., "rows": [...]}."""
    from ...gpu.session import default_session
    check_config(cfg)
    log = cfg.log or (lambda line: None)
    session = default_session(cfg.backend, 0)
    rows: list[dict] = []
    use_reference = cfg.reference and reference_available()
    if cfg.reference and not use_reference:
        log("note: sdfpbr.reference is not installed; error columns stay empty")
    heat_dir = Path(cfg.heatmaps) if cfg.heatmaps else None
    if heat_dir is not None:
        heat_dir.mkdir(parents=True, exist_ok=True)

    for scene in cfg.scenes:
        ref = noise = other = None
        if use_reference:
            ref = get_reference(session, scene_spec(scene, cfg), cfg.ref_samples, cfg.seed, log)
            other = get_reference(session, scene_spec(scene, cfg), cfg.ref_samples, cfg.seed + 1, log)
            noise = noise_floor(ref, other)
            log(f"{scene}: reference noise floor (FLIP between seeds {cfg.seed} and {cfg.seed + 1}): {noise:.4f}")
        for preset in cfg.presets:
            spec = scene_spec(scene, cfg, preset)
            log(f"{scene} / {preset}: timing {cfg.repeats} draws at {spec.width}x{spec.height} ...")
            t = time_chart(session, spec, cfg.repeats, cfg.warmup)
            row = timing_row(scene, preset, spec, t)
            log(f"  warm-up: {t.draw.warmup_draws} draws, "
                + ("draw times settled" if t.draw.settled else "draw times did NOT settle (timings are noisy)"))
            if cfg.cold:
                row.update(zip(COLD_COLUMNS, cold_times(scene_overrides(scene), preset, cfg)))
            if ref is not None:
                path = heat_dir / f"flip_{scene}_{preset}.png" if heat_dir else None
                row.update(error_columns(t.result, ref, spec, path, f"{scene} / {preset}", noise, other))
            rows.append(row)
            log("  " + format_row(row))

    if cfg.baseline:
        rows.append(baseline_row(session, cfg))
        log("  " + format_row(rows[-1]))
    if cfg.ablation:
        rows += ablation_rows(session, cfg, log)

    machine = machine_info(session)
    settings = {k: v for k, v in vars(cfg).items() if k != "log"}
    return {"machine": machine, "settings": settings, "rows": rows}


def machine_info(session) -> dict:
    """What a report was measured on."""
    return {"gl_renderer": session.renderer, "cpu_count": os.cpu_count(),
            "python": sys.version.split()[0], "sdfpbr": __version__}


def baseline_row(session, cfg: BenchConfig) -> dict:
    """Time a Shadertoy-style shader at the bench resolution, the same way as the chart."""
    import moderngl
    from ..baseline import VERTEX_SHADER, build_program, load_shadertoy, set_shadertoy_uniforms
    src = load_shadertoy(cfg.baseline)
    ctx = session.ctx
    W, H = cfg.width, cfg.height
    with session:
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
        "scene": "shadertoy", "preset": "baseline", "shader": src.origin, "entry_point": src.entry,
        "width": W, "height": H, "spheres": None,
        "render_ms": timing.median_ms, "render_ms_min": timing.min_ms, "render_ms_mad": timing.mad_ms,
        "render_samples_ms": timing.samples_ms, "timing": timing.method,
        "warmup_draws": timing.warmup_draws, "settled": timing.settled,
        "compile_ms": link + first, "link_ms": link, "first_draw_ms": first,
        "source_bytes": len(src.code.encode()), **dict.fromkeys(COLD_COLUMNS),
        "flip_mean": None, "rel_rmse": None,
        "note": "the shader's own scene, camera and lights at iTime=0: timing only, "
                "an error against our reference would not be meaningful",
    }
