"""Ground truth for the chart: a progressive Monte Carlo path tracer of exactly the chart's scene.

Same sphere grid, ground, camera, environment function (env.glsl evaluated per ray, not the
baked cubemap), lights and BRDF module (brdf.glsl, compensation on or off as the spec says)
as the chart, on the same GL context. What the chart approximates, the reference does exactly:
analytic ray-sphere/plane visibility for every ray, true shadow rays for every light and
for the environment (no AO), the sun as a disc of finite radiance, interreflections.

Sampling: GGX visible normals (Heitz 2018) mixed with cosine-weighted diffuse, one light
sample per light and one environment sample (a tabulated equirect CDF) per surface point,
combined by multiple importance sampling with the power heuristic. Pixel samples follow the
R2 sequence under a per-pixel random rotation; all random numbers are hashes of (seed,
pixel, sample, draw), so a seed gives bit-identical output.

The energy compensation's single-scatter albedo E(NdotV, r) comes from a float64 quadrature
table (sdfpbr.mirror), not the chart's sampled LUT, so the reference integrates the model
itself rather than the chart's approximation of it. For the schlick-ggx model the reference
uses the punctual-light visibility (k = (r+1)^2/8) for every direction, since a path tracer
needs one BRDF; the chart's IBL uses k = alpha/2 and differs from it by construction.

Error: per pixel, the standard error of the mean of the samples' luminance, from running
sums kept about a per-pixel shift. The stopping metric is the MEAN RELATIVE STANDARD ERROR
over sphere pixels (pixels whose centre ray hits a sphere): mean of stderr / max(mean, floor)
with floor = 1% of the mean luminance of those pixels, so near-black pixels do not dominate.
Pixel samples are stratified, so the per-pixel estimate is conservative (it assumes
independent samples).
"""
from __future__ import annotations

import math
import sys
import time
import weakref
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..shading.camera import Camera
from ..shading.compose import ComposedSource, compose
from ..errors import SpecError
from ..spec.chart_spec import ChartSpec

DEFAULT_MAX_BOUNCES = 4        # surface interactions per path; 1 = direct light only
DEFAULT_SAMPLES = 64           # per pixel, when neither samples nor a target error is given
DEFAULT_TARGET_CAP = 16384     # most samples per pixel when only a target error is given
MAX_SAMPLES = 1 << 20
MAX_BOUNCES = 64
MAX_SIDE = 4096                # accumulators are full-size float images
MAX_CELL_REACH = 8             # spheres overlapping more than this many cells are refused
MIN_SAMPLES_FOR_TARGET = 16    # the variance estimate needs some samples before it is trusted
SAMPLES_PER_BATCH = 1 << 18    # paths per batch over the whole image (batches of >= 1 spp)
TILE = 128                     # pixels per dispatch edge: keeps each dispatch short on a CPU
COMPENSATION_TABLE_SIZE = 128  # E(NdotV, r) grid, float64 quadrature (bilinear error < 4e-4)
COMPENSATION_QUADRATURE = 16   # Gauss-Legendre order: within 7e-7 of order 32 on this grid
ENV_MAP_SIZE = (512, 256)      # equirect sampling table (W, H)
ENV_SUPERSAMPLE = 2            # env evaluations per texel edge
RELATIVE_FLOOR = 0.01
LOCAL = 8


@dataclass
class ReferenceResult:
    hdr: np.ndarray          # (H, W, 3) float32 linear radiance, before exposure (premultiplied if transparent)
    alpha: np.ndarray        # (H, W) coverage
    stderr: np.ndarray       # (H, W) float32 standard error of the mean luminance (NaN below 2 samples)
    samples: int             # samples per pixel reached
    error: float             # mean relative standard error over sphere pixels (see module doc)
    image: np.ndarray        # (H, W, 4) uint8 display image through the chart's display program
    aov: dict                # normal, depth, row, col, roughness, metallic, ndotv (chart layout)
    camera: Camera
    source: ComposedSource
    seed: int
    max_bounces: int
    non_finite: int          # samples dropped as NaN/Inf (expected 0)
    timings: dict = field(default_factory=dict)


def scene_spec(spec: ChartSpec) -> ChartSpec:
    """The scene the reference renders: ``spec`` without its catalogued bugs and with the
    default quality preset, since both only describe how the chart approximates (or gets
    wrong) the scene; a preset's forced BRDF model is one of those approximations, so the
    reference uses ``spec.brdf``."""
    from ..spec.chart_spec import make_spec
    return make_spec(spec, bugs=(), quality="default")


def reference_options(spec: ChartSpec) -> dict:
    """Compile options of the reference program: the chart's options for the scene (the
    reference modules ignore those for IBL, AO, soft shadows and marching)."""
    from ..gpu.render import chart_options
    return chart_options(scene_spec(spec))


def reference_source(spec: ChartSpec) -> ComposedSource:
    return compose("reference_main.glsl", reference_options(spec))


def cell_reach(spec: ChartSpec) -> int:
    """How many cells away from its own a sphere reaches (0 unless spheres overlap cells)."""
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


# ---- per-context state: tables uploaded once per renderer -------------------------------

_state: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _renderer_state(renderer) -> dict:
    if renderer not in _state:
        _state[renderer] = {}
    return _state[renderer]


def compensation_table(model: str, cache=None) -> np.ndarray:
    """(size, size, 4) float32: [j, i] = (A, B, C, 1) at NdotV = i/(size-1), r = j/(size-1),
    the layout dfg.glsl reads, by float64 quadrature (sdfpbr.mirror), disk-cached."""
    from ..oracle import mirror
    from ..cache import content_key
    size, order = COMPENSATION_TABLE_SIZE, COMPENSATION_QUADRATURE
    key = content_key("reference-dfg", model, size, order, Path(mirror.__file__).read_bytes())
    cached = cache.get("reference_dfg", key) if cache is not None else None
    if cached is not None:
        return cached["table"]
    grid = np.arange(size, dtype=np.float64) / (size - 1)
    a, b, c = mirror.dfg_integrate(np.maximum(grid[None, :], mirror.MIN_N_DOT_V), grid[:, None], model=model, n=order)
    table = np.stack([a, b, c, np.ones_like(a)], axis=-1).astype(np.float32)
    if cache is not None:
        cache.put("reference_dfg", key, {"table": table})
    return table


def _compensation_texture(renderer, model: str):
    import moderngl
    state = _renderer_state(renderer)
    name = "dfg:" + model
    if name not in state:
        table = compensation_table(model, renderer.cache)
        size = table.shape[0]
        tex = renderer.ctx.texture((size, size), 4, np.ascontiguousarray(table).tobytes(), dtype="f4")
        tex.repeat_x = tex.repeat_y = False
        tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        state[name] = tex
    return state[name]


def environment_cdfs(radiance: np.ndarray) -> dict | None:
    """Sampling tables from an (H, W, 3) equirect average radiance map (row 0 at the zenith):
    texel probabilities P proportional to (luminance + floor) sin(theta), the marginal CDF
    over rows and the conditional CDF within each row. None when the map has no radiance."""
    h, w = radiance.shape[:2]
    lum = radiance[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])
    sin_theta = np.sin((np.arange(h) + 0.5) / h * np.pi)[:, None]
    mean = float(np.sum(lum * sin_theta) / (np.sum(sin_theta) * w))
    if not (math.isfinite(mean) and mean > 0.0):
        return None
    # A floor keeps every direction samplable (MIS stays unbiased where the table missed light).
    weight = (np.maximum(lum, 0.0) + 1e-3 * mean) * sin_theta
    p = weight / weight.sum()
    row = p.sum(axis=1)
    marginal = np.concatenate([[0.0], np.cumsum(row)])
    marginal /= marginal[-1]
    conditional = np.concatenate([np.zeros((h, 1)), np.cumsum(p, axis=1)], axis=1) / row[:, None]
    conditional[:, -1] = 1.0
    return {"marginal": marginal.astype(np.float32)[None, :], "conditional": conditional.astype(np.float32),
            "probability": p.astype(np.float32)}


def _environment_sampling(renderer, spec: ChartSpec, env) -> dict | None:
    """Per-context textures for environment sampling, keyed by the environment's content."""
    import moderngl
    from ..gpu.programs import set_uniforms
    state = _renderer_state(renderer)
    name = "env:" + env.content
    if name in state:
        return state[name]
    ctx = renderer.ctx
    tables = None
    if env.option != "black":
        program = renderer.programs.compute(compose("reference_env_main.glsl", {"ENV": env.option}))
        w, h = ENV_MAP_SIZE
        target = ctx.texture((w, h), 4, dtype="f4")
        target.bind_to_image(0, read=False, write=True)
        uniforms = {**env.uniforms, "u_size": (w, h), "u_supersample": ENV_SUPERSAMPLE}
        if env.texture is not None:
            env.texture.use(4)
            uniforms["u_env_map"] = 4
        set_uniforms(program, uniforms)
        program.run((w + LOCAL - 1) // LOCAL, (h + LOCAL - 1) // LOCAL)
        ctx.memory_barrier()
        radiance = np.frombuffer(target.read(), np.float32).reshape(h, w, 4)
        target.release()
        tables = environment_cdfs(radiance)
    textures = None
    if tables is not None:
        textures = {}
        for key, uniform in (("marginal", "u_env_marginal_cdf"), ("conditional", "u_env_conditional_cdf"),
                             ("probability", "u_env_texel_probability")):
            data = np.ascontiguousarray(tables[key], np.float32)
            tex = ctx.texture((data.shape[1], data.shape[0]), 1, data.tobytes(), dtype="f4")
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            textures[uniform] = tex
        textures["size"] = (tables["probability"].shape[1], tables["probability"].shape[0])
    state[name] = textures
    return textures


# ---- progress ------------------------------------------------------------------------------

class _Progress:
    """tqdm on a terminal when installed (extra `progress`), else a plain stderr line at most
    every few seconds; silent when disabled."""

    def __init__(self, enabled: bool, total: int, target: float | None):
        self.enabled, self.total, self.target = enabled, total, target
        self.bar = None
        self.last_line = time.monotonic()
        if enabled and sys.stderr.isatty():
            try:
                from tqdm import tqdm
            except ImportError:
                tqdm = None
            if tqdm is not None:
                self.bar = tqdm(total=total, unit="spp", desc="reference", file=sys.stderr)

    def update(self, done: int, added: int, error: float | None) -> None:
        if not self.enabled:
            return
        err = "" if error is None or not math.isfinite(error) else f"rel. stderr {error:.2%}"
        if self.target is not None and err:
            err += f" (target {self.target:.2%})"
        if self.bar is not None:
            self.bar.update(added)
            if err:
                self.bar.set_postfix_str(err, refresh=False)
        elif time.monotonic() - self.last_line >= 5.0 or done >= self.total:
            self.last_line = time.monotonic()
            print(f"sdfpbr reference: {done}/{self.total} spp {err}".rstrip(), file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


# ---- rendering -----------------------------------------------------------------------------

def _tiles(width: int, height: int):
    for y0 in range(0, height, TILE):
        for x0 in range(0, width, TILE):
            yield x0, y0, min(TILE, width - x0), min(TILE, height - y0)


def _read(tex, width: int, height: int) -> np.ndarray:
    """An RGBA float image, top row first (GL rows run bottom-up)."""
    return np.frombuffer(tex.read(), np.float32).reshape(height, width, 4)[::-1]


def _statistics(sum_rgba: np.ndarray, moments: np.ndarray, n: int):
    mean = sum_rgba / n
    if n < 2:
        return mean, np.full(mean.shape[:2], np.nan, np.float32)
    s1 = moments[..., 0].astype(np.float64)
    s2 = moments[..., 1].astype(np.float64)
    var = np.maximum(s2 - s1 * s1 / n, 0.0) / (n - 1)
    return mean, np.sqrt(var / n).astype(np.float32)


def _display(renderer, spec: ChartSpec, mean_rgba_gl: np.ndarray) -> np.ndarray:
    """The chart's display program (exposure, tone map, OETF) on the mean radiance."""
    from ..gpu.programs import set_uniforms
    from ..gpu.render import display_source
    import moderngl
    ctx = renderer.ctx
    h, w = mean_rgba_gl.shape[:2]
    display = renderer.programs.fragment(display_source(spec))
    radiance = ctx.texture((w, h), 4, np.ascontiguousarray(mean_rgba_gl, np.float32).tobytes(), dtype="f4")
    ldr = ctx.texture((w, h), 4)
    fbo = ctx.framebuffer(color_attachments=[ldr])
    fbo.use()
    radiance.use(15)
    set_uniforms(display, {"u_radiance": 15, "u_exposure_scale": 2.0 ** spec.exposure,
                           "u_reinhard_white": spec.reinhard_white})
    vao = ctx.vertex_array(display, [])
    vao.render(moderngl.TRIANGLES, vertices=3)
    image = np.frombuffer(ldr.read(), np.uint8).reshape(h, w, 4)[::-1].copy()
    for obj in (vao, fbo, ldr, radiance):
        obj.release()
    return image


def _aovs(renderer, spec: ChartSpec, options: dict, uniforms: dict) -> dict:
    """The AOVs of the pixel-centre rays, traced exactly, in the chart's layout."""
    from ..gpu.programs import set_uniforms
    ctx = renderer.ctx
    w, h = spec.width, spec.height
    program = renderer.programs.compute(compose("reference_aov_main.glsl", options))
    targets = [ctx.texture((w, h), 4, dtype="f4") for _ in range(2)]
    for unit, tex in enumerate(targets):
        tex.bind_to_image(unit, read=False, write=True)
    set_uniforms(program, uniforms)
    for x0, y0, tw, th in _tiles(w, h):
        set_uniforms(program, {"u_tile_origin": (x0, y0), "u_tile_size": (tw, th)})
        program.run((tw + LOCAL - 1) // LOCAL, (th + LOCAL - 1) // LOCAL)
    ctx.memory_barrier()
    normal_depth, cells = (_read(t, w, h) for t in targets)
    for t in targets:
        t.release()
    col = np.rint(cells[..., 0]).astype(np.int32)
    row = np.rint(cells[..., 1]).astype(np.int32)
    sphere = (row >= 0) & (col >= 0)
    col[~sphere] = -1
    row[~sphere] = -1
    roughness = np.full((h, w), np.nan, np.float32)
    metallic = np.full((h, w), np.nan, np.float32)
    roughness[sphere] = np.asarray(spec.column_roughness(), np.float32)[col[sphere]]
    metallic[sphere] = np.asarray(spec.row_metallic(), np.float32)[row[sphere]]
    return {"normal": normal_depth[..., :3].copy(), "depth": normal_depth[..., 3].copy(), "row": row, "col": col,
            "roughness": roughness, "metallic": metallic, "ndotv": cells[..., 2].copy()}


def render_reference(spec: ChartSpec, samples: int | None = None, target_error: float | None = None,
                     seed: int = 0, max_bounces: int = DEFAULT_MAX_BOUNCES, progress: bool = False,
                     renderer=None, *, lambert: bool = False) -> ReferenceResult:
    """Path-trace ``spec`` until ``samples`` per pixel, or until the mean relative standard
    error over sphere pixels reaches ``target_error`` (checked after each batch once 16
    samples are in; ``samples`` then caps the run, default 16384). Without either: 64 spp.

    ``max_bounces``: surface interactions per path; 1 is direct light only (lights and the
    environment with exact visibility, no interreflection), the default 4 follows light
    through three interreflections (paths are cut there, no Russian roulette: deterministic,
    bias = the light of longer paths). ``renderer`` defaults to the chart's renderer for
    (spec.backend, spec.device_index), so both share one context. ``lambert`` replaces every
    BRDF by a Lambert reflector of its base colour (a check of the integrator itself).
    """
    samples, target_error, seed, max_bounces = validate_arguments(spec, samples, target_error, seed, max_bounces)
    if renderer is None:
        from ..api import get_renderer
        renderer = get_renderer(spec.backend, spec.device_index)
    with renderer.ctx:
        return _render(renderer, spec, samples, target_error, seed, max_bounces, progress, bool(lambert))


def _render(renderer, spec, samples, target_error, seed, max_bounces, progress, lambert) -> ReferenceResult:
    from ..shading import camera as camera_mod
    from ..gpu.ibl import make_environment
    from ..gpu.programs import set_uniforms
    from ..gpu.render import chart_uniforms
    ctx = renderer.ctx
    timings = {}
    t0 = time.perf_counter()
    options = reference_options(spec)
    source = compose("reference_main.glsl", options)
    program = renderer.programs.compute(source)
    timings["compile_s"] = time.perf_counter() - t0

    t1 = time.perf_counter()
    cam = camera_mod.frame_grid(spec)
    env = make_environment(ctx, spec)
    owned = [env.texture] if env.texture is not None else []   # released when done
    try:
        uniforms = chart_uniforms(scene_spec(spec), cam)
        uniforms.update(env.uniforms)
        uniforms.update({"u_cell_reach": cell_reach(spec), "u_max_bounces": max_bounces,
                         "u_lambert_only": int(lambert), "u_seed": seed})
        textures = [("u_dfg", _compensation_texture(renderer, spec.brdf))]
        env_tables = _environment_sampling(renderer, spec, env)
        uniforms["u_env_sampling"] = int(env_tables is not None)
        uniforms["u_env_map_size"] = env_tables["size"] if env_tables is not None else (1, 1)
        if env_tables is not None:
            textures += [(k, v) for k, v in env_tables.items() if k != "size"]
        if env.texture is not None:
            textures.append(("u_env_map", env.texture))
        if options["USE_TEXTURES"]:
            from ..gpu.textures import texture_set, upload
            surface_maps = upload(ctx, texture_set(spec))
            owned += surface_maps.values()
            textures += surface_maps.items()
        for unit, (name, tex) in enumerate(textures):
            tex.use(unit)
            uniforms[name] = unit
        timings["setup_s"] = time.perf_counter() - t1

        t2 = time.perf_counter()
        aov = _aovs(renderer, spec, options, uniforms)
        sphere = aov["row"] >= 0
        timings["aov_s"] = time.perf_counter() - t2

        t3 = time.perf_counter()
        set_uniforms(program, uniforms)
        w, h = spec.width, spec.height
        zeros = np.zeros((h, w, 4), np.float32).tobytes()
        sum_tex = ctx.texture((w, h), 4, zeros, dtype="f4")
        moments_tex = ctx.texture((w, h), 4, zeros, dtype="f4")
        owned += [sum_tex, moments_tex]
        sum_tex.bind_to_image(0, read=True, write=True)
        moments_tex.bind_to_image(1, read=True, write=True)
        # Drivers that compile at first use, per texture state (Mesa), do it on this empty
        # dispatch: counted as compile time, not as sampling time.
        t_warm = time.perf_counter()
        set_uniforms(program, {"u_tile_size": (0, 0)})
        program.run(1, 1)
        ctx.finish()
        timings["compile_s"] += time.perf_counter() - t_warm
        t3 = time.perf_counter()
        done = _accumulate(ctx, program, sum_tex, moments_tex, w, h, samples, target_error, sphere, progress)
        sum_gl = np.frombuffer(sum_tex.read(), np.float32).reshape(h, w, 4)
        moments = _read(moments_tex, w, h)
    finally:
        for tex in owned:
            tex.release()
    timings["render_s"] = time.perf_counter() - t3
    timings["s_per_spp_per_mpx"] = timings["render_s"] / done / (w * h / 1e6)

    mean, stderr = _statistics(sum_gl[::-1], moments, done)
    error = relative_error(_luminance(mean), stderr, sphere) if done >= 2 else float("nan")
    t4 = time.perf_counter()
    image = _display(renderer, scene_spec(spec), sum_gl / done)
    timings["display_s"] = time.perf_counter() - t4
    return ReferenceResult(hdr=np.ascontiguousarray(mean[..., :3], np.float32), alpha=mean[..., 3].copy(),
                           stderr=stderr, samples=done, error=error, image=image, aov=aov, camera=cam,
                           source=source, seed=seed, max_bounces=max_bounces,
                           non_finite=int(moments[..., 3].sum()), timings=timings)


def _accumulate(ctx, program, sum_tex, moments_tex, w, h, samples, target_error, sphere, progress) -> int:
    """Run batches until ``samples`` per pixel or the target error; returns the samples done.
    The error is checked on a schedule that depends only on the sample count (every batch
    up to 5 % more samples), so where a run stops does not depend on timing."""
    from ..gpu.programs import set_uniforms
    per_batch = batch_size(w, h)
    bar = _Progress(progress, samples, target_error)
    done, error = 0, float("nan")
    next_check = min(MIN_SAMPLES_FOR_TARGET, samples)
    last_shown = -math.inf
    try:
        while done < samples:
            count = min(per_batch, samples - done)
            for x0, y0, tw, th in _tiles(w, h):
                set_uniforms(program, {"u_tile_origin": (x0, y0), "u_tile_size": (tw, th),
                                       "u_sample_start": done, "u_sample_count": count})
                program.run((tw + LOCAL - 1) // LOCAL, (th + LOCAL - 1) // LOCAL)
                ctx.memory_barrier()
            done += count
            check = target_error is not None and done >= next_check
            show = progress and done >= 2 and (time.monotonic() - last_shown >= 2.0 or done >= samples)
            if check or show:   # reading the sums back also waits for the batch
                mean, stderr = _statistics(_read(sum_tex, w, h), _read(moments_tex, w, h), done)
                error = relative_error(_luminance(mean), stderr, sphere)
                last_shown = time.monotonic()
            else:
                ctx.finish()
            bar.update(done, count, error)
            if check:
                if error <= target_error:
                    break
                next_check = done + max(per_batch, done // 20)
    finally:
        bar.close()
    return done


def _luminance(rgba: np.ndarray) -> np.ndarray:
    return rgba[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)


# ---- labeled output --------------------------------------------------------------------------

def footer_text(spec: ChartSpec, result: ReferenceResult) -> str:
    from ..api import footer_scene_parts
    err = f", rel. stderr {result.error:.2%}" if math.isfinite(result.error) else ""
    parts = footer_scene_parts(spec, spec.brdf) + [
        f"path-traced reference, {result.samples} spp, {result.max_bounces} bounces{err}"]
    return "  |  ".join(parts)


def label(spec: ChartSpec, result: ReferenceResult) -> np.ndarray:
    """The chart's labeled layout around the reference render."""
    from .. import api
    return api.label(spec, result, title=f"Roughness × metallic — {spec.rows}×{spec.cols} (reference)",
                       footer=footer_text(spec, result))
