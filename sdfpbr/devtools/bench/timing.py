"""Timing on a GL context: median draw times (a timer query where it measures execution, else
the wall clock between ctx.finish() calls), compile times of programs no cache has seen, and
the chart program's draw alone."""
from __future__ import annotations

import math
import statistics
import time
import uuid
from dataclasses import dataclass

import numpy as np

from ...gpu.frame import tiles
from ...spec.chart_spec import ChartSpec
from .cold import COLD_COLUMNS
from .suite import BenchConfig


@dataclass
class DrawTiming:
    median_ms: float
    min_ms: float
    mad_ms: float          # median absolute deviation: the noise of this measurement
    method: str            # "gl-timer-query" or "finish-wall-clock"
    samples_ms: list
    warmup_draws: int = 0  # untimed draws before the timed ones
    settled: bool = True   # the warm-up ended because draw times had settled (see warm_up)


# Warm-up: a GPU raises its clocks only under sustained load (the H100 timed one default draw
# at 8.9 ms cold and 1.6 ms settled), so draws are repeated until the medians of two
# consecutive windows agree within SETTLE_RTOL, for at most SETTLE_MAX_S seconds.
SETTLE_WINDOW = 5
SETTLE_RTOL = 0.05
SETTLE_MAX_S = 20.0
SETTLE_MAX_S_SOFTWARE = 3.0   # a CPU rasterizer has no GPU clocks to raise; its noise is the machine's


_SOFTWARE_RASTERIZERS = ("llvmpipe", "softpipe", "swrast", "lavapipe")


def timer_query_measures_execution(ctx) -> bool:
    """Mesa's software rasterizers answer GL_TIME_ELAPSED with the time to queue a draw (a few
    ms for a 60 ms draw), not to run it; hardware drivers time the execution."""
    renderer = str(ctx.info.get("GL_RENDERER", "")).lower()
    return not any(name in renderer for name in _SOFTWARE_RASTERIZERS)


def settled(times: list[float]) -> bool:
    """Whether draw times have settled: the median of the last SETTLE_WINDOW is within
    SETTLE_RTOL of the median of the window before it."""
    if len(times) < 2 * SETTLE_WINDOW:
        return False
    recent = statistics.median(times[-SETTLE_WINDOW:])
    before = statistics.median(times[-2 * SETTLE_WINDOW:-SETTLE_WINDOW])
    return abs(recent - before) <= SETTLE_RTOL * before


def warm_up(ctx, draw, min_draws: int, max_seconds: float = SETTLE_MAX_S) -> tuple[int, bool]:
    """Draw at least ``min_draws`` times, then until the median wall time of the last
    SETTLE_WINDOW draws is within SETTLE_RTOL of the window before it. Returns (draws, settled);
    settled is False when ``max_seconds`` ran out first."""
    times: list[float] = []
    start = time.perf_counter()
    while True:
        ctx.finish()
        t0 = time.perf_counter()
        draw()
        ctx.finish()
        times.append(time.perf_counter() - t0)
        if len(times) >= min_draws and settled(times):
            return len(times), True
        if time.perf_counter() - start > max_seconds and len(times) >= min_draws:
            return len(times), False


def time_draws(ctx, draw, repeats: int, warmup: int = 1) -> DrawTiming:
    """Median draw time after a warm-up that lasts until draw times settle (at least ``warmup``
    draws): a GL timer query where it measures execution (hardware), else the wall clock
    between ctx.finish() calls. One method per context, so rows compare."""
    hardware = timer_query_measures_execution(ctx)
    warmup_draws, settled = warm_up(ctx, draw, warmup, SETTLE_MAX_S if hardware else SETTLE_MAX_S_SOFTWARE)
    query = None
    if hardware:
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
    return DrawTiming(med, min(samples), mad, method, [round(s, 3) for s in samples], warmup_draws, settled)


def within_noise(a: DrawTiming, b: DrawTiming) -> bool:
    """Two medians agree within 3 MADs of either run plus 3 % (the machine is shared)."""
    return abs(a.median_ms - b.median_ms) <= 3.0 * max(a.mad_ms, b.mad_ms) + 0.03 * max(a.median_ms, b.median_ms)


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
    if "u_sample_range" in program:   # a supersampled chart's first sample, as one ray's chart draws
        program["u_sample_range"] = (0, 1)
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


def time_chart(session, spec: ChartSpec, repeats: int, warmup: int, compile_time: bool = True) -> ChartTiming:
    """Render once (programs, IBL bakes), then time a frame's draws alone into the same float
    targets the renderer uses: its per-frame passes (the cells stage's floor prepass) and the
    chart program's tiles."""
    from ...shading.plan import render_plan
    from ...gpu.prepasses import bind_frame
    from ...gpu.render import ChartDraw, chart_scene
    result = session.render(spec)
    ctx = session.ctx
    plan = render_plan(spec)
    source = plan.chart
    with session:
        chart = ChartDraw(session, plan, shader="fragment")
        scene = chart_scene(session, plan)
        W, H = spec.width, spec.height
        passes = []
        for x0, y0, tw, th in tiles(W, H, session.tile):
            targets = [ctx.texture((tw, th), 4, dtype="f4") for _ in range(3)]
            passes.append((x0, y0, tw, th, targets, ctx.framebuffer(color_attachments=targets)))

        def draw():   # what a frame draws: its per-frame passes, then the chart's tiles (and edges)
            bind_frame(session, plan, scene, chart.programs, cached=False)   # drawn, as a moving frame's
            for x0, y0, tw, th, targets, fbo in passes:
                chart.draw(x0, y0, tw, th, targets, fbo)

        timing = time_draws(ctx, draw, repeats, warmup)
        radiance = np.empty((H, W, 3), np.float32)
        for x0, y0, tw, th, targets, _ in passes:
            tile = np.frombuffer(targets[0].read(), np.float32).reshape(th, tw, 4)[::-1, :, :3]
            radiance[H - y0 - th:H - y0, x0:x0 + tw] = tile
        scale = max(float(np.abs(result.hdr).max()), 1e-6)
        check = float(np.abs(radiance - result.hdr).max()) / scale
        chart.release()
        scene.release()
        for *_, targets, fbo in passes:
            fbo.release()
            for t in targets:
                t.release()
        link = first = math.nan
        if compile_time:
            link, first = time_compile(ctx, plan.vertex.text, source.text, [(4, "f4")] * 3)
    return ChartTiming(result, timing, link, first, len(source.text.encode()), check)


def time_interleaved(session, specs: list[ChartSpec], cfg: BenchConfig, rounds: int = 3) -> list[ChartTiming]:
    """Time several specs in alternating rounds (A B C A B C ...), so a load change on the
    shared machine hits all of them alike; each draw timing is the median over every round's
    samples. Compile times come from the first round."""
    first: list[ChartTiming] = []
    samples: list[list[float]] = [[] for _ in specs]
    for r in range(rounds):
        for i, spec in enumerate(specs):
            t = time_chart(session, spec, cfg.repeats, cfg.warmup, compile_time=(r == 0))
            samples[i] += t.draw.samples_ms
            if r == 0:
                first.append(t)
    out = []
    for t, s in zip(first, samples):
        med = statistics.median(s)
        t.draw = DrawTiming(med, min(s), statistics.median(abs(x - med) for x in s), t.draw.method, s,
                            t.draw.warmup_draws, t.draw.settled)
        out.append(t)
    return out


def timing_row(scene: str, preset: str, spec: ChartSpec, t: ChartTiming) -> dict:
    """A result row with the timing columns filled and the others empty."""
    return {
        "scene": scene, "preset": preset, "width": spec.width, "height": spec.height,
        "spheres": spec.rows * spec.cols,
        "render_ms": t.draw.median_ms, "render_ms_min": t.draw.min_ms, "render_ms_mad": t.draw.mad_ms,
        "render_samples_ms": t.draw.samples_ms, "timing": t.draw.method,
        "warmup_draws": t.draw.warmup_draws, "settled": t.draw.settled,
        "compile_ms": t.link_ms + t.first_draw_ms, "link_ms": t.link_ms, "first_draw_ms": t.first_draw_ms,
        "source_bytes": t.source_bytes, "draw_check": t.draw_check,
        **dict.fromkeys(COLD_COLUMNS),
        "flip_mean": None, "flip_sphere_mean": None, "hdr_flip_mean": None, "rel_rmse": None,
    }
