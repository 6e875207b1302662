"""Render a chart spec to linear HDR radiance, AOVs and the display image on a session.

One pass of the chart program per tile (a supersampled pixel's samples over as many as a
software renderer's loop limit needs) writes radiance + coverage and the AOVs into float
targets; the display pass applies exposure, the tone mapper and the sRGB OETF. Arrays come
back top row first."""
from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field

import moderngl
import numpy as np

from ..errors import SpecError
from ..shading.camera import Camera
from ..shading.compose import ComposedSource
from ..shading.plan import ChartFrame, GridShapes, RenderPlan, render_plan
from ..shading.sheen import sheen_centroid_uniform
from ..spec.chart_spec import ChartSpec
from .loop_guard import LoopGuard, cut_error
from .frame import AOVBuffers, SceneBindings, display_pass, image_slices, read_rgba, scene_bindings, tiles
from .prepasses import bind_frame
from .programs import set_uniforms

TILE = 2048   # largest tile edge; also bounds the float targets' memory


@dataclass
class RenderResult:
    hdr: np.ndarray | None   # (H, W, 3) float32 linear radiance, before exposure (None: not read)
    alpha: np.ndarray | None # (H, W) coverage, read with hdr
    image: np.ndarray        # (H, W, 4) uint8 display image (sRGB)
    aov: dict                # normal, depth, row, col, roughness, metallic, ndotv, coverage ({}: not read)
    frame: ChartFrame        # where the render's spheres lie (its plan's frame)
    chart_source: ComposedSource
    display_source: ComposedSource
    timings: dict = field(default_factory=dict)

    @property
    def camera(self) -> Camera:
        return self.frame.camera


# Host bytes a pixel of a render holds: image 4 and the labelled chart 4 x ~1.4 (its margins
# grow with the render: 9735 x 9362 around 8192²; the API draws the image into the chart, other
# callers label a copy); the PNG is encoded a block of rows at a time, from the chart itself.
# hdr adds 12 and alpha 4, the AOVs 32 (tests/test_tiling.py measures the arrays; an 8192²
# chart through the CLI peaks at 0.66 GB, 0.3 GB of it GL and the interpreter).
HOST_BYTES_PER_PIXEL = 10
HDR_BYTES_PER_PIXEL = 16
AOV_BYTES_PER_PIXEL = 32


def available_memory() -> int | None:
    """Bytes this process may still allocate: MemAvailable, capped by RLIMIT_AS (None: unknown)."""
    limits = []
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    limits.append(int(line.split()[1]) * 1024)
    except OSError:
        pass
    try:
        import resource
        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft != resource.RLIM_INFINITY:
            with open("/proc/self/statm") as f:
                used = int(f.read().split()[0]) * resource.getpagesize()
            limits.append(max(soft - used, 0))
    except (ImportError, OSError, ValueError):
        pass
    return min(limits) if limits else None


def check_memory(spec: ChartSpec, aovs: bool, hdr: bool = True) -> None:
    """Refuse, before any work, a chart whose arrays cannot fit in this process's memory."""
    per_pixel = HOST_BYTES_PER_PIXEL + (HDR_BYTES_PER_PIXEL if hdr else 0) + (AOV_BYTES_PER_PIXEL if aovs else 0)
    need = spec.width * spec.height * per_pixel
    have = available_memory()
    if have is not None and need > have:
        extras = " and ".join(name for name, on in (("HDR", hdr), ("AOVs", aovs)) if on)
        raise SpecError(f"a {spec.width}x{spec.height} chart needs about {need / 2**30:.1f} GiB of memory"
                        f"{' with ' + extras if extras else ''}; about {have / 2**30:.1f} GiB are available: "
                        f"render it smaller")


def render_chart(session, spec: ChartSpec, aovs: bool = True, plan: RenderPlan | None = None,
                 hdr: bool = True, image: np.ndarray | None = None) -> RenderResult:
    """``spec`` on ``session`` (entered by the caller). Only what is asked is read back: the
    display image always; linear radiance and coverage with ``hdr`` (result.hdr, .alpha: None
    otherwise); the AOVs with ``aovs`` (result.aov: {} otherwise, and their targets are not
    even attached). ``image``: a (height, width, 4) uint8 array (a view, e.g. the render area
    of a labelled chart) the display image is drawn into, tile by tile, instead of a new one."""
    if image is not None and (image.shape != (spec.height, spec.width, 4) or image.dtype != np.uint8):
        raise ValueError(f"the image to draw into must be ({spec.height}, {spec.width}, 4) uint8, "
                         f"not {image.dtype} {image.shape}")
    check_memory(spec, aovs, hdr)
    t0 = time.perf_counter()
    timings = {}
    plan = plan or render_plan(spec)
    chart = ChartDraw(session, plan)
    try:
        display = session.programs.fragment(plan.display)
        timings["compile_s"] = time.perf_counter() - t0

        t1 = time.perf_counter()
        scene = chart_scene(session, plan)
        try:
            timings["setup_s"] = time.perf_counter() - t1
            t2 = time.perf_counter()
            bind_frame(session, plan, scene, chart.programs)
            radiance, alpha, image, aov = _draw(session, chart, display, plan.frame, aovs, hdr, image)
            timings["render_s"] = time.perf_counter() - t2
        finally:
            scene.release()
    finally:
        chart.release()
    return RenderResult(radiance, alpha, image, aov, plan.frame, plan.chart, plan.display, timings)


def redisplay(session, spec: ChartSpec, source: RenderResult) -> RenderResult:
    """``spec``'s render from ``source``, a render (its HDR read) of a spec that differs from
    ``spec`` in display fields alone (fields.same_radiance: the caller checks): its radiance
    through ``spec``'s display pass, tile by tile as render_chart draws. The display image is
    the one render_chart gives (the display pass reads the same texels: float32, or float16
    read back exactly); a tone-map or exposure sweep draws its chart once."""
    if source.hdr is None or source.hdr.shape[:2] != (spec.height, spec.width):
        raise ValueError("redisplay needs a render of the same size with its HDR read")
    t0 = time.perf_counter()
    plan = render_plan(spec)
    display = session.programs.fragment(plan.display)
    ctx, H, W = session.ctx, spec.height, spec.width
    image = np.empty((H, W, 4), np.uint8)
    for x0, y0, tw, th in tiles(W, H, session.tile):
        where = image_slices(H, x0, y0, tw, th)
        rgba = np.empty((th, tw, 4), np.float32)
        rgba[..., :3], rgba[..., 3] = source.hdr[where], source.alpha[where]
        radiance = ctx.texture((tw, th), 4, rgba[::-1].tobytes(), dtype="f4")   # GL rows run bottom-up
        try:
            image[where] = display_pass(ctx, display, radiance, plan.frame, tw, th, session.targets, origin=(x0, y0))
        finally:
            radiance.release()
    return RenderResult(source.hdr, source.alpha, image, {}, plan.frame, source.chart_source, plan.display,
                        {"render_s": time.perf_counter() - t0})


def chart_scene(session, plan: RenderPlan) -> SceneBindings:
    """The scene's bindings with the lighting the chart program reads: DFG LUT, and the baked
    environment, ground table and stage probe where the plan has them (cached bakes)."""
    scene = scene_bindings(session.ctx, plan.frame, plan.options["USE_TEXTURES"], session.cache)
    if plan.options.get("SHEEN_LEAN"):   # where the sheen lobe gathers its light (lobes_ibl.glsl)
        scene.uniforms["u_sheen_centroid"] = sheen_centroid_uniform()
    try:
        dfg = session.ibl.dfg(plan)
        scene.add_texture("u_dfg", dfg, key=session.ibl.dfg_key(plan))
        if plan.ibl is not None:
            lighting = session.ibl.lighting(scene.environment, plan.ibl)
            baked = []
            if plan.ibl.ground_table is not None:   # the ground's IBL per view direction
                ground = session.ibl.ground_table(plan, lighting, dfg, scene.uniforms)
                scene.add_texture("u_ground_ibl", ground.texture, key=ground.key)
                baked.append(ground.key)
            if plan.ibl.stage_probe is not None:   # the spheres see the stage (its floor), not the sky below
                lighting = session.ibl.stage_lighting(plan.ibl, plan.ibl.stage_probe, lighting, scene.textures,
                                                      scene.uniforms, scene.environment, tuple(baked))
            scene.uniforms.update(lighting.uniforms())
            scene.add_texture("u_prefiltered", lighting.prefiltered, key=lighting.key)
            if plan.ibl.floor_parallax is not None:   # the floor as each sphere point sees it
                scene.add_texture("u_floor_parallax", session.ibl.floor_parallax(plan.ibl, lighting, scene.uniforms),
                                  key=lighting.floor_parallax_key)
    except BaseException:
        scene.release()
        raise
    return scene


class GridInstances:
    """``shapes`` (the plan's), drawn once per instance on a grid (grid_instances_vert.glsl)
    with ``program``, whose vertex stage that is."""

    def __init__(self, ctx, program, shapes: GridShapes):
        self.program, self.instances = program, shapes.instances
        self.uniforms = {"u_instance_origin": tuple(map(float, shapes.origin)), "u_instance_step": tuple(shapes.step),
                         "u_instances_x": shapes.per_row}
        self.buffer = ctx.buffer(np.ascontiguousarray(shapes.triangles, np.float32).tobytes())
        try:
            self.vao = ctx.vertex_array(program, [(self.buffer, "2f", "in_position")])
        except BaseException:
            self.buffer.release()
            raise

    def render(self, target_origin, target_size) -> None:
        """Into the bound framebuffer, whose viewport is ``target_size`` pixels from the
        target's pixel ``target_origin``."""
        set_uniforms(self.program, {**self.uniforms, "u_target_origin": tuple(map(float, target_origin)),
                                    "u_target_size": tuple(target_size)})
        self.vao.render(moderngl.TRIANGLES, instances=self.instances)

    def release(self) -> None:
        self.vao.release()
        self.buffer.release()


@functools.lru_cache(maxsize=64)
def sample_lattice_step(spp: int) -> int:
    """The generator g of a pixel's spp samples, the rank-1 lattice ((i + 1/2) / spp, (i g mod spp
    + 1/2) / spp) (chart_main.glsl sample_offset): g coprime with spp, so each axis holds every
    stratum once and the points' mean is the pixel's centre, as the reference's box integral's
    is; of those, the one whose points lie farthest apart on the torus (nearest spp / golden
    ratio on a tie), not on a few lines (g = 9 of 16 put half of them on the diagonal)."""
    if spp <= 2:
        return 1
    i = np.arange(1, spp)
    best, best_key = 1, None
    for g in range(1, spp):
        if math.gcd(g, spp) != 1:
            continue
        d = np.minimum(i, spp - i) ** 2 + np.minimum(i * g % spp, spp - i * g % spp) ** 2
        key = (int(d.min()), -abs(g - spp / 1.618033988749895))
        if best_key is None or key > best_key:
            best, best_key = g, key
    return best


def sample_ranges(spp: int, per_draw: int) -> list[tuple[int, int]]:
    """[first, end) of each draw's samples when ``per_draw`` of a pixel's ``spp`` go in one."""
    return [(first, min(first + per_draw, spp)) for first in range(0, spp, per_draw)]


class ChartDraw:
    """The chart's programs for a frame and what they draw with: the compute program, or the
    fragment program over each whole tile, then (SPHERE_PIXELS) its sphere pass over each
    sphere's box, which draws over the spheres' pixels, then (EDGE_PIXELS) its edge pass over a
    ring round each silhouette, which draws over the silhouettes' pixels."""

    def __init__(self, session, plan: RenderPlan, shader: str | None = None):
        """``shader``: "fragment" or "compute" (None: the session's chart_shader)."""
        ctx = self.ctx = session.ctx
        self.compute = (shader or session.chart_shader) == "compute"
        self.vao = None
        self.session, self.spec = session, plan.spec
        # A supersampled pixel's samples go in as few draws as the renderer's loop limit allows
        # (loop_guard.glsl), which add up in the targets; the session remembers the count per
        # program.
        self.supersample = plan.options["SUPERSAMPLE"]
        self.half = plan.options["HALF_RADIANCE"]
        self.sample_step = sample_lattice_step(plan.spec.spp)
        self.program_key = (plan.chart_compute if self.compute else plan.chart).digest
        self.guard = None
        self.overlays: list[GridInstances] = []   # the sphere and edge passes, in their order
        if self.compute:
            self.program = session.programs.compute(plan.chart_compute)
            self.programs = [self.program]
            self.guard = LoopGuard(ctx)
            return
        self.program = session.programs.fragment(plan.chart)
        self.programs = [self.program]
        try:
            self.guard = LoopGuard(ctx)
            self.vao = ctx.vertex_array(self.program, [])
            for source, shapes in ((plan.sphere_pass, plan.sphere_shapes), (plan.edge_pass, plan.edge_shapes)):
                if source is None:
                    continue
                program = session.programs.fragment(source, plan.instances_vertex)
                self.programs.append(program)
                self.overlays.append(GridInstances(ctx, program, shapes))
        except BaseException:
            self.release()
            raise

    def draw(self, x0: int, y0: int, tw: int, th: int, targets: list, fbo=None) -> None:
        """The tile at (x0, y0) of (tw, th) pixels into ``targets`` (radiance, then the AOVs'
        when they are read): through ``fbo`` (bound here) on the fragment path, as images
        0..2 for the compute program, which stores the AOVs only when they are bound."""
        spp = self.spec.spp
        known = self.session.samples_per_draw
        per_draw = min(known.get(self.program_key, spp), spp)
        while True:
            self._draw_samples(x0, y0, tw, th, targets, fbo,
                               sample_ranges(spp, per_draw) if self.supersample else [None])
            cut = self.guard.cut()
            if not cut:
                break
            if not self.supersample or per_draw == 1:
                raise cut_error(self.session.renderer, cut)
            per_draw = max(1, per_draw // 4)
            known[self.program_key] = per_draw

    def _draw_samples(self, x0, y0, tw, th, targets, fbo, draws) -> None:
        """One pass over the tile per entry of ``draws``: a range of a supersampled pixel's
        samples, whose draws add up from zero, or None (the pixel's one ray)."""
        self.guard.arm(*self.programs)
        if self.compute:
            for unit, target in enumerate(targets):   # read where a later draw adds to them
                target.bind_to_image(unit, read=True, write=True)
            for draw in draws:
                set_uniforms(self.program, {"u_tile_origin": (x0, y0), "u_tile_size": (tw, th),
                                            "u_write_aovs": len(targets) > 1, "u_sample_range": draw,
                                            "u_sample_step": self.sample_step})
                self.program.run((tw + 7) // 8, (th + 7) // 8, 1)
                self.ctx.memory_barrier()
            return
        fbo.use()
        for program in self.programs:
            set_uniforms(program, {"u_tile_origin": (x0, y0), "u_sample_step": self.sample_step})
        adding = len(draws) > 1   # the later draws add to the first (chart_main.glsl)
        if adding:
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            self.ctx.enable(moderngl.BLEND)
            self.ctx.blend_func = moderngl.ONE, moderngl.ONE
            self.ctx.blend_equation = moderngl.FUNC_ADD
        try:
            for draw in draws:
                set_uniforms(self.program, {"u_sample_range": draw})
                self.vao.render(moderngl.TRIANGLES, vertices=3)
        finally:
            if adding:   # back to GL's defaults
                self.ctx.blend_func = moderngl.ONE, moderngl.ZERO
                self.ctx.disable(moderngl.BLEND)
        for overlay in self.overlays:
            overlay.render((x0, y0), (tw, th))

    def release(self) -> None:
        for obj in (self.vao, *self.overlays, self.guard):
            if obj is not None:
                obj.release()
        self.vao, self.overlays, self.guard = None, [], None


def _draw(session, chart: ChartDraw, display, frame: ChartFrame, aovs: bool, read_hdr: bool,
          image: np.ndarray | None):
    ctx, pool = session.ctx, session.targets
    spec = frame.spec
    W, H = spec.width, spec.height
    # Tiles are read straight into the final arrays: no full-size 4-channel staging copies.
    hdr = np.empty((H, W, 3), np.float32) if read_hdr else None
    alpha = np.empty((H, W), np.float32) if read_hdr else None
    image = np.empty((H, W, 4), np.uint8) if image is None else image
    aov = AOVBuffers(spec, H, W) if aovs else None
    half = chart.half
    # Radiance, then (normal, depth) and (col, row, NdotV, coverage) when the AOVs are read:
    # without their targets the program's writes to those outputs go nowhere.
    dtypes = ("f2" if half else "f4",) + (("f4", "f4") if aovs else ())
    for x0, y0, tw, th in tiles(W, H, session.tile):
        targets = [pool.take(tw, th, dtype) for dtype in dtypes]
        fbo = None if chart.compute else ctx.framebuffer(color_attachments=targets)
        try:
            chart.draw(x0, y0, tw, th, targets, fbo)
            where = image_slices(H, x0, y0, tw, th)
            # Targets are read through the framebuffer (glReadPixels) where there is one.
            source = targets if fbo is None else [fbo] * len(targets)
            image[where] = display_pass(ctx, display, targets[0], frame, tw, th, pool, origin=(x0, y0))
            if read_hdr:
                radiance = read_rgba(source[0], tw, th, np.float16 if half else np.float32, pool)
                hdr[where] = radiance[..., :3]
                alpha[where] = radiance[..., 3]
            if aov is not None:
                aov.write(where, read_rgba(source[1], tw, th, pool=pool, slot=1, attachment=1),
                          read_rgba(source[2], tw, th, pool=pool, slot=2, attachment=2))
        finally:
            if fbo is not None:
                fbo.release()
            for tex in targets:
                pool.give(tex)
    return hdr, alpha, image, (aov.finish() if aov is not None else {})
