"""A GL session: one context and what lives on it — compiled programs, the IBL and DFG bakes,
per-session tables, the on-disk array cache — handed explicitly to whatever renders.

A session is used by one thread at a time: entering it (``with session:``) takes its lock and
makes its context current, so threads may share one session (they take turns) or each make
their own. ``default_session`` gives the process one per (backend, device), created on first
use; it is the only module-level GL state in sdfpbr."""
from __future__ import annotations

import os
import threading
from contextlib import contextmanager

import moderngl

from ..cache import ArrayCache
from ..errors import SpecError
from ..shading.plan import CHART_SHADERS
from .gl import create_context, renderer_string
from .ibl import IBLBaker
from .programs import ProgramCache
from .frame import TargetPool
from .render import TILE, RenderResult, redisplay, render_chart


SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swiftshader")


def chart_shader_for(renderer: str) -> str:
    """Which program draws the chart on a renderer: the compute shader on a hardware GPU (on
    an H100 the same raymarch loop ran 30.7x faster as a compute shader than as a fragment
    shader: few of its units run fragments), the fragment shader on a software rasterizer
    (llvmpipe: compute takes 0.95-1.08x the fragment path's time, so nothing is gained there;
    BENCHMARKS.md). $SDFPBR_CHART_SHADER (fragment or compute) overrides the rule."""
    forced = os.environ.get("SDFPBR_CHART_SHADER", "")
    if forced:
        if forced not in CHART_SHADERS:
            raise SpecError(f"SDFPBR_CHART_SHADER must be one of {', '.join(CHART_SHADERS)}, got {forced!r}")
        return forced
    return "fragment" if any(name in renderer.lower() for name in SOFTWARE_RENDERERS) else "compute"


class Session:
    def __init__(self, ctx: moderngl.Context | None = None, cache: ArrayCache | None = None, *,
                 tile: int | None = None, backend: str = "auto", device_index: int = 0,
                 chart_shader: str | None = None):
        self.ctx = ctx if ctx is not None else create_context(backend, device_index)
        self.backend = getattr(self.ctx, "extra", None) and self.ctx.extra.get("backend") or backend
        self.device_index = device_index
        self.lock = threading.RLock()
        self._depth = 0          # nesting of `with session:` in the thread that holds the lock
        self.programs = ProgramCache(self.ctx)
        self.cache = cache or ArrayCache()
        self.renderer = renderer_string(self.ctx)
        self.ibl = IBLBaker(self.ctx, self.programs, self.cache, self.renderer)
        self.tables: dict = {}   # GPU tables other integrators keep per session (the reference's)
        if chart_shader is not None and chart_shader not in CHART_SHADERS:
            raise SpecError(f"chart_shader must be one of {', '.join(CHART_SHADERS)}, got {chart_shader!r}")
        self.chart_shader = chart_shader or chart_shader_for(self.renderer)   # see chart_shader_for
        # Per chart program (its source's digest), how many of a pixel's samples one draw may
        # take within the renderer's loop limit (gpu/render.py ChartDraw, found where the limit
        # cut a draw short).
        self.samples_per_draw: dict[str, int] = {}
        self.targets = TargetPool(self.ctx)   # render targets kept between renders
        # Tiles never exceed what the context can render into; images larger than that are tiled.
        # Tile edges are whole multiples of 4, so every tile starts on the 4x4 pixel blocks of the
        # untiled render: llvmpipe takes some sampling decisions (cube-map faces) per block, and
        # tiles at other offsets changed ~1 % of IBL pixels by an ulp (found by `sdfpbr stress`).
        with self:
            info = self.ctx.info
            self.max_texture_size = info["GL_MAX_TEXTURE_SIZE"]
            limit = min(tile or TILE, info["GL_MAX_TEXTURE_SIZE"], *info["GL_MAX_VIEWPORT_DIMS"])
        self.tile = max(4, limit // 4 * 4)

    def __enter__(self) -> "Session":
        self.lock.acquire()
        try:
            if self._depth == 0:
                self.ctx.__enter__()   # make current; inner enters keep it current
            self._depth += 1
        except BaseException:
            self.lock.release()
            raise
        return self

    def __exit__(self, *exc) -> None:
        try:
            self._depth -= 1
            if self._depth == 0:
                self.ctx.__exit__(*exc)
        finally:
            self.lock.release()

    def render(self, spec, aovs: bool = True, hdr: bool = True, image=None, plan=None) -> RenderResult:
        """Render ``spec``, reading back the display image (into ``image`` when given) and what
        else is asked (see gpu.render.render_chart); ``plan``: its render_plan, where the
        caller has it (the labels read its frame first)."""
        with self:
            return render_chart(self, spec, aovs, plan=plan, hdr=hdr, image=image)

    def redisplay(self, spec, source: RenderResult) -> RenderResult:
        """``spec``'s render from ``source``'s radiance (see gpu.render.redisplay)."""
        with self:
            return redisplay(self, spec, source)

    @contextmanager
    def turning_light(self, light: int = 0):
        """A block of renders in which directional light ``light`` turns about the vertical and
        nothing else changes in the cells stage's probe (a light orbit): the probes after the
        first are composed from the first's bakes instead of baked (IBLBaker.begin_orbit)."""
        with self:
            self.ibl.begin_orbit(light)
        try:
            yield self
        finally:
            with self:
                self.ibl.end_orbit()

    def release(self) -> None:
        with self:
            self.ibl.end_orbit()
            self.targets.release()
        with self.lock:
            self.ctx.release()


_defaults: dict[tuple[str, int], Session] = {}
_defaults_lock = threading.Lock()


def default_session(backend: str = "auto", device_index: int = 0) -> Session:
    """The process's session for (backend, device), created on first use."""
    key = (backend, device_index)
    with _defaults_lock:   # two threads asking at once get one session, not two contexts
        if key not in _defaults:
            _defaults[key] = Session(backend=backend, device_index=device_index)
        return _defaults[key]
