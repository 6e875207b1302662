"""The reference's integrator loop: batches of samples per pixel on the session, running sums
and moments per pixel, the stopping rule, and the result in the chart's layout."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ...errors import SpecError
from ...gpu.frame import AOVBuffers, display_pass, read_rgba, scene_bindings, tiles
from ...gpu.loop_guard import LoopGuard, cut_error
from ...gpu.programs import set_uniforms
from ...gpu.session import Session, default_session
from ...progress import Progress
from ...shading.camera import Camera
from ...shading.compose import ComposedSource
from ...shading.plan import ChartFrame, ReferencePlan, reference_plan
from ...spec.chart_spec import ChartSpec
from .tables import compensation_choice, compensation_texture, environment_sampling

# Surface interactions per path (1 = direct light only): enough for the light between a white
# sphere and a white floor to converge (sky only, 128², mean luminance: 4 bounces -2.2 %,
# 8 -0.47 %, 16 -0.07 %, 32 -0.008 % against 64; the floor at the sphere's foot was 17 % dark
# at 4). A 128² default chart's reference takes 13 % longer than at 4 bounces.
DEFAULT_MAX_BOUNCES = 32
DEFAULT_SAMPLES = 64           # per pixel, when neither samples nor a target error is given
DEFAULT_TARGET_CAP = 16384     # most samples per pixel when only a target error is given
MAX_SAMPLES = 1 << 20
MAX_BOUNCES = 64
MAX_SIDE = 4096                # accumulators are full-size float images
MAX_CELL_REACH = 8             # spheres overlapping more than this many cells are refused
MIN_SAMPLES_FOR_TARGET = 16    # the variance estimate needs some samples before it is trusted
SAMPLES_PER_BATCH = 1 << 18    # paths per batch over the whole image (batches of >= 1 spp)
TILE = 128                     # pixels per dispatch edge: keeps each dispatch short on a CPU
RELATIVE_FLOOR = 0.01
LOCAL = 8


# A spec's fields that do not change its reference's pixels: the reference has no quality
# preset, and where it runs or how the chart is labelled is not the scene.
PRESENTATION_FIELDS = ("quality", "backend", "device_index", "labels", "title")


def scene_fields(spec: ChartSpec) -> dict:
    """The spec's fields a reference's pixels depend on (with its seed and bounces)."""
    d = spec.to_dict()
    for name in PRESENTATION_FIELDS:
        d.pop(name, None)
    return d


def run_key(spec: ChartSpec, seed: int, max_bounces: int = DEFAULT_MAX_BOUNCES, lambert: bool = False) -> str:
    """Names the sample sequence of a reference: runs with one key differ only in how many
    samples they took."""
    from ...cache import content_key
    return content_key("reference-run", scene_fields(spec), int(seed), int(max_bounces), bool(lambert))


@dataclass
class Accumulators:
    """The integrator's running state after ``samples`` per pixel of the run ``run`` (run_key),
    top row first: per-pixel sums of the samples (RGBA), the luminance moments about a per-pixel
    shift (x: sum of shifted values, y: sum of their squares, z: the shift, w: non-finite
    samples dropped) and, with a shadow catcher, its sums. Samples are added one by one in
    sample order, so a run resumed from the state after n samples equals, bit for bit, a run
    that went straight on."""
    sums: np.ndarray
    moments: np.ndarray
    catcher: np.ndarray | None
    samples: int
    run: str


@dataclass
class ReferenceResult:
    hdr: np.ndarray          # (H, W, 3) float32 linear radiance, before exposure (premultiplied if transparent)
    alpha: np.ndarray        # (H, W) coverage
    stderr: np.ndarray       # (H, W) float32 standard error of the mean luminance (NaN below 2 samples)
    samples: int             # samples per pixel reached
    error: float             # mean relative standard error over sphere pixels (see the package doc)
    image: np.ndarray        # (H, W, 4) uint8 display image through the chart's display program
    aov: dict                # normal, depth, row, col, roughness, metallic, ndotv (chart layout)
    frame: ChartFrame        # where its spheres lie (its plan's frame)
    source: ComposedSource
    seed: int
    max_bounces: int
    non_finite: int          # samples dropped as NaN/Inf (expected 0)
    timings: dict = field(default_factory=dict)
    accumulators: Accumulators | None = None   # the state to resume from for more samples

    @property
    def camera(self) -> Camera:
        return self.frame.camera


def cell_reach(spec: ChartSpec) -> int:
    """How many cells away from its own a sphere reaches (0 unless spheres overlap cells; 0
    on the cells stage, where each cell's scene holds its own sphere only)."""
    if spec.stage == "cells":
        return 0
    return max(0, math.ceil(spec.sphere_radius / spec.spacing - 0.5))


def _whole(value, what: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise SpecError(f"{what} must be a whole number in [{lo}, {hi}], got {value!r}")
    return int(value)


def validate_arguments(spec: ChartSpec, samples=None, target_error=None, seed=0,
                       max_bounces=DEFAULT_MAX_BOUNCES) -> tuple[int, float | None, int, int]:
    """(samples cap, target error or None, seed, bounces), or SpecError naming what is allowed."""
    if not isinstance(spec, ChartSpec):
        raise SpecError(f"spec must be a ChartSpec, got {type(spec).__name__}")
    if target_error is not None:
        if isinstance(target_error, bool) or not isinstance(target_error, (int, float)) \
                or not math.isfinite(target_error) or not 0.0 < target_error <= 1.0:
            raise SpecError(f"target error must be a relative error in (0, 1], got {target_error!r}")
        target_error = float(target_error)
    if samples is None:
        samples = DEFAULT_SAMPLES if target_error is None else DEFAULT_TARGET_CAP
    samples = _whole(samples, "samples", 1, MAX_SAMPLES)
    seed = _whole(seed, "seed", 0, 2**32 - 1)
    max_bounces = _whole(max_bounces, "bounces", 1, MAX_BOUNCES)
    if spec.width > MAX_SIDE or spec.height > MAX_SIDE:
        raise SpecError(f"the reference renders at most {MAX_SIDE}x{MAX_SIDE} pixels, got {spec.width}x{spec.height}")
    if cell_reach(spec) > MAX_CELL_REACH:
        raise SpecError(f"the reference needs spacing >= {spec.sphere_radius / (MAX_CELL_REACH + 0.5):.4g} "
                        f"for sphere_radius {spec.sphere_radius:g} (spheres may overlap at most "
                        f"{MAX_CELL_REACH} cells), got spacing {spec.spacing:g}")
    return samples, target_error, seed, max_bounces


def batch_size(width: int, height: int) -> int:
    """Samples per pixel per batch: a fixed function of the image size, so the summation order,
    and with it every bit of the result, depends only on (spec, seed, samples)."""
    return int(min(64, max(1, SAMPLES_PER_BATCH // (width * height))))


def relative_error(mean_luminance: np.ndarray, stderr: np.ndarray, sphere: np.ndarray) -> float:
    """The stopping metric: mean over sphere pixels of stderr / max(mean, 1% of their mean)."""
    mask = sphere if sphere.any() else np.ones_like(sphere)
    m = mean_luminance[mask].astype(np.float64)
    se = stderr[mask].astype(np.float64)
    floor = max(RELATIVE_FLOOR * float(np.mean(np.abs(m))), 1e-12)
    return float(np.mean(se / np.maximum(np.abs(m), floor)))


def _statistics(sum_rgba: np.ndarray, moments: np.ndarray, n: int):
    mean = sum_rgba / n
    if n < 2:
        return mean, np.full(mean.shape[:2], np.nan, np.float32)
    s1 = moments[..., 0].astype(np.float64)
    s2 = moments[..., 1].astype(np.float64)
    var = np.maximum(s2 - s1 * s1 / n, 0.0) / (n - 1)
    return mean, np.sqrt(var / n).astype(np.float32)


def _luminance(rgba: np.ndarray) -> np.ndarray:
    return rgba[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)


def _dispatch(program, width: int, height: int, uniforms: dict) -> None:
    """Run a compute program over the image in TILE-sized dispatches (short on a CPU)."""
    for x0, y0, tw, th in tiles(width, height, TILE):
        set_uniforms(program, {**uniforms, "u_tile_origin": (x0, y0), "u_tile_size": (tw, th)})
        program.run((tw + LOCAL - 1) // LOCAL, (th + LOCAL - 1) // LOCAL)


def _aovs(session: Session, plan: ReferencePlan, spec: ChartSpec, uniforms: dict) -> dict:
    """The AOVs of the pixel-centre rays, traced exactly, decoded as the chart decodes its own."""
    ctx = session.ctx
    w, h = spec.width, spec.height
    program = session.programs.compute(plan.aov)
    targets = [ctx.texture((w, h), 4, dtype="f4") for _ in range(2)]
    try:
        for unit, tex in enumerate(targets):
            tex.bind_to_image(unit, read=False, write=True)
        set_uniforms(program, uniforms)
        _dispatch(program, w, h, {})
        ctx.memory_barrier()
        buffers = AOVBuffers(spec, h, w)
        buffers.write((slice(None), slice(None)), read_rgba(targets[0], w, h), read_rgba(targets[1], w, h))
        return buffers.finish()
    finally:
        for t in targets:
            t.release()


def render_reference(spec: ChartSpec, samples: int | None = None, target_error: float | None = None,
                     seed: int = 0, max_bounces: int = DEFAULT_MAX_BOUNCES, progress: bool = False,
                     session: Session | None = None, *, lambert: bool = False,
                     resume: Accumulators | None = None) -> ReferenceResult:
    """Path-trace ``spec`` until ``samples`` per pixel, or until the mean relative standard
    error over sphere pixels reaches ``target_error`` (checked after each batch once 16
    samples are in; ``samples`` then caps the run, default 16384). Without either: 64 spp.

    ``max_bounces``: surface interactions per path; 1 is direct light only (lights and the
    environment with exact visibility, no interreflection), the default 32 follows light
    until what is left is under 1e-4 of it (paths are cut there, no Russian roulette:
    deterministic, bias = the light of longer paths). ``session`` defaults to the process's session for
    (spec.backend, spec.device_index), so the chart and its reference share one context.
    ``lambert`` replaces every BRDF by a Lambert reflector of its base colour (a check of the
    integrator itself).
    ``resume``: the accumulators of an earlier run of the same spec, seed, bounces and
    lambert flag with fewer samples (its result's ``accumulators``); the run goes on from its
    state, and equals bit for bit a run of ``samples`` from the start. Fixed sample counts
    only: a target error's stopping schedule starts at the first sample.
    """
    samples, target_error, seed, max_bounces = validate_arguments(spec, samples, target_error, seed, max_bounces)
    run = run_key(spec, seed, max_bounces, lambert)
    if resume is not None:
        _check_resume(resume, run, spec, samples, target_error)
    session = session or default_session(spec.backend, spec.device_index)
    with session:
        return _render(session, spec, samples, target_error, seed, max_bounces, progress, bool(lambert), resume, run)


def _check_resume(resume: Accumulators, run: str, spec: ChartSpec, samples: int, target_error) -> None:
    if target_error is not None:
        raise SpecError("a reference resumes to a sample count, not to a target error")
    if resume.run != run:
        raise SpecError("the accumulators to resume from are another run's: another scene, seed, bounce count "
                        "or lambert flag")
    if not 0 < resume.samples < samples:
        raise SpecError(f"a resumed reference needs more samples than its {resume.samples}, got {samples}")
    shape = (spec.height, spec.width, 4)
    arrays = [resume.sums, resume.moments] + ([] if resume.catcher is None else [resume.catcher])
    if any(np.shape(a) != shape for a in arrays):
        raise SpecError(f"the accumulators to resume from are not {spec.width}x{spec.height} RGBA")


def _render(session: Session, spec, samples, target_error, seed, max_bounces, progress, lambert,
            resume: Accumulators | None, run: str) -> ReferenceResult:
    ctx = session.ctx
    timings = {}
    t0 = time.perf_counter()
    plan = reference_plan(spec)
    program = session.programs.compute(plan.integrator)
    timings["compile_s"] = time.perf_counter() - t0

    t1 = time.perf_counter()
    scene = scene_bindings(ctx, plan.frame, plan.options["USE_TEXTURES"], session.cache)
    owned = []
    try:
        scene.uniforms.update({"u_cell_reach": cell_reach(spec), "u_max_bounces": max_bounces,
                               "u_lambert_only": int(lambert), "u_seed": seed})
        scene.add_texture("u_dfg", compensation_texture(session, **compensation_choice(spec, plan)))
        env_tables = environment_sampling(session, plan.env_table, scene.environment)
        scene.uniforms["u_env_sampling"] = int(env_tables is not None)
        scene.uniforms["u_env_map_size"] = env_tables["size"] if env_tables is not None else (1, 1)
        for name, tex in (env_tables or {}).items():
            if name != "size":
                scene.add_texture(name, tex)
        uniforms = scene.bind()
        timings["setup_s"] = time.perf_counter() - t1

        t2 = time.perf_counter()
        aov = _aovs(session, plan, spec, uniforms)
        sphere = aov["row"] >= 0
        timings["aov_s"] = time.perf_counter() - t2

        set_uniforms(program, uniforms)
        w, h = spec.width, spec.height
        zeros = np.zeros((h, w, 4), np.float32).tobytes()

        def start(name):   # a texture's first contents: zeros, or the state resumed from
            state = None if resume is None else getattr(resume, name)
            return zeros if state is None else np.ascontiguousarray(state[::-1], np.float32).tobytes()

        sum_tex = ctx.texture((w, h), 4, start("sums"), dtype="f4")
        moments_tex = ctx.texture((w, h), 4, start("moments"), dtype="f4")
        owned += [sum_tex, moments_tex]
        sum_tex.bind_to_image(0, read=True, write=True)
        moments_tex.bind_to_image(1, read=True, write=True)
        first = 0 if resume is None else resume.samples
        # each pixel's next sample
        next_tex = ctx.texture((w, h), 1, np.full((h, w), first, np.uint32).tobytes(), dtype="u4")
        guard = LoopGuard(ctx)
        owned += [next_tex, guard]
        next_tex.bind_to_image(3, read=True, write=True)
        catcher_tex = None
        if plan.options.get("SHADOW_CATCHER"):   # the floor's light with and without the spheres
            catcher_tex = ctx.texture((w, h), 4, start("catcher"), dtype="f4")
            owned.append(catcher_tex)
            catcher_tex.bind_to_image(2, read=True, write=True)
        # Drivers that compile at first use, per texture state (Mesa), do it on this empty
        # dispatch: counted as compile time, not as sampling time.
        t_warm = time.perf_counter()
        set_uniforms(program, {"u_tile_size": (0, 0)})
        program.run(1, 1)
        ctx.finish()
        timings["compile_s"] += time.perf_counter() - t_warm
        t3 = time.perf_counter()
        batches = Batches(ctx, program, guard, session.renderer, w, h)
        done = _accumulate(batches, sum_tex, moments_tex, first, samples, target_error, sphere, progress)
        moments = read_rgba(moments_tex, w, h).copy()
        timings["render_s"] = time.perf_counter() - t3
        timings["s_per_spp_per_mpx"] = timings["render_s"] / done / (w * h / 1e6)

        t4 = time.perf_counter()
        state = Accumulators(read_rgba(sum_tex, w, h).copy(), moments, None, done, run)
        sums = state.sums
        if catcher_tex is not None:
            state.catcher = read_rgba(catcher_tex, w, h).copy()
            sums = sums.copy()
            sums[..., 3] += catcher_coverage(state.catcher)
        # The mean, as a texture (GL rows bottom-up), through the chart's display program.
        mean_tex = ctx.texture((w, h), 4, np.ascontiguousarray(sums[::-1] / done, np.float32).tobytes(), dtype="f4")
        owned.append(mean_tex)
        image = display_pass(ctx, session.programs.fragment(plan.display), mean_tex, plan.frame, w, h)
        timings["display_s"] = time.perf_counter() - t4
    finally:
        scene.release()
        for tex in owned:
            tex.release()

    mean, stderr = _statistics(sums, moments, done)
    error = relative_error(_luminance(mean), stderr, sphere) if done >= 2 else float("nan")
    return ReferenceResult(hdr=np.ascontiguousarray(mean[..., :3], np.float32), alpha=mean[..., 3].copy(),
                           stderr=stderr, samples=done, error=error, image=image.copy(), aov=aov, frame=plan.frame,
                           source=plan.integrator, seed=seed, max_bounces=max_bounces,
                           non_finite=int(moments[..., 3].sum()), timings=timings, accumulators=state)


def catcher_coverage(catcher: np.ndarray) -> np.ndarray:
    """The shadow catcher's summed coverage per pixel from (sum L, sum L_open, floor-first
    paths, each counted by its cell's border fade on the cells stage): each such path counts
    1 - sum L / sum L_open, clamped to [0, 1] as the chart's shadow_catcher does (0 where the
    open floor is black)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        kept = np.where(catcher[..., 1] > 0.0, catcher[..., 0] / catcher[..., 1], 1.0)
    return catcher[..., 2] * (1.0 - np.clip(kept, 0.0, 1.0))


class Batches:
    """Draws a batch of samples into every pixel's sums. A software rasterizer ends every loop
    of an invocation, silently, past its limit (gpu/loop_guard.py): a 10 x 10 grid of mirrors,
    16 lights and 64 bounces at 32² lost 7 % of its light at 64 samples a dispatch. An
    invocation cut short stores nothing (reference_main.glsl), and the batch is drawn again,
    from each pixel's next sample, with a quarter as many samples a dispatch, a count the run
    keeps: the sums take every pixel's samples in order, bit for bit those of one sample a
    dispatch."""

    def __init__(self, ctx, program, guard: LoopGuard, renderer: str, width: int, height: int):
        self.ctx, self.program, self.guard, self.renderer = ctx, program, guard, renderer
        self.width, self.height = width, height
        self.per_dispatch = batch_size(width, height)

    def draw(self, end: int, count: int) -> None:
        """Every pixel's samples up to ``end``, ``count`` of them."""
        while True:
            self.guard.arm(self.program)
            per = min(self.per_dispatch, count)
            for _ in range(-(-count // per)):   # enough for a pixel that has none of them yet
                for x0, y0, tw, th in tiles(self.width, self.height, TILE):
                    set_uniforms(self.program, {"u_tile_origin": (x0, y0), "u_tile_size": (tw, th),
                                                "u_sample_end": end, "u_sample_count": per})
                    self.program.run((tw + LOCAL - 1) // LOCAL, (th + LOCAL - 1) // LOCAL)
                    self.ctx.memory_barrier()
            cut = self.guard.cut()
            if not cut:
                return
            if per == 1:
                raise cut_error(self.renderer, cut, "one sample of this reference",
                                "lower the bounces (--bounces), the grid or the lights, or render on a GPU")
            self.per_dispatch = max(1, per // 4)


def _accumulate(batches: Batches, sum_tex, moments_tex, first, samples, target_error, sphere, progress) -> int:
    """Run batches from sample ``first`` until ``samples`` per pixel or the target error;
    returns the samples done. The error is checked on a schedule that depends only on the
    sample count (every batch up to 5 % more samples), so where a run stops does not depend
    on timing."""
    ctx, w, h = batches.ctx, batches.width, batches.height
    per_batch = batch_size(w, h)
    bar = Progress(samples, "sdfpbr reference", unit="spp", enabled=progress)
    if first:
        bar.update(first, "")
    done, error = first, float("nan")
    next_check = min(MIN_SAMPLES_FOR_TARGET, samples)
    last_shown = -math.inf
    with bar:
        while done < samples:
            count = min(per_batch, samples - done)
            batches.draw(done + count, count)
            done += count
            check = target_error is not None and done >= next_check
            show = progress and done >= 2 and (time.monotonic() - last_shown >= 2.0 or done >= samples)
            if check or show:   # reading the sums back also waits for the batch
                mean, stderr = _statistics(read_rgba(sum_tex, w, h), read_rgba(moments_tex, w, h), done)
                error = relative_error(_luminance(mean), stderr, sphere)
                last_shown = time.monotonic()
            else:
                ctx.finish()
            bar.update(count, _error_note(error, target_error))
            if check:
                if error <= target_error:
                    break
                next_check = done + max(per_batch, done // 20)
    return done


def _error_note(error: float, target: float | None) -> str:
    if not math.isfinite(error):
        return ""
    return f"rel. stderr {error:.2%}" + (f" (target {target:.2%})" if target is not None else "")
