"""Render a chart spec to linear HDR radiance, AOVs and the display image.

One pass of the chart program per tile writes radiance + coverage and the AOVs into float
targets; a display pass applies exposure, the tone mapper and the sRGB OETF. Arrays come
back top row first."""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import moderngl
import numpy as np

from ..shading import camera as camera_mod
from ..cache import ArrayCache
from ..spec.bugs import bug_options
from ..shading.compose import ComposedSource, compose
from .ibl import IBLBaker, env_option, make_environment
from .programs import ProgramCache, set_uniforms
from ..spec.chart_spec import ChartSpec

TILE = 2048   # largest tile edge; also bounds the float targets' memory


def chart_options(spec: ChartSpec) -> dict:
    """The compile-time options of the chart program: every feature the spec leaves out is
    absent from the composed source."""
    directional = sum(1 for l in spec.lights if l.kind == "directional")
    point = sum(1 for l in spec.lights if l.kind == "point")
    q = spec.quality_settings()
    opts = {
        "BRDF_MODEL": spec.brdf_model().replace("-", "_"),
        "ENV": env_option(spec),
        "CAMERA": spec.camera,
        "INTERSECT": "analytic" if spec.uses_analytic_intersection() else "march",
        "HAS_GROUND": spec.ground,
        "USE_IBL": spec.ibl,
        "USE_AO": spec.ibl and spec.ao,
        # The key light (the first directional light) casts shadows onto the ground.
        "USE_SHADOWS": spec.shadows and spec.ground and directional > 0,
        "MULTISCATTER": spec.multiscatter,
        "TRANSPARENT": spec.transparent,
        "NUM_DIR_LIGHTS": directional,
        "NUM_POINT_LIGHTS": point,
        "GRID_ROWS": spec.rows,
        "HALF_RADIANCE": spec.hdr_precision == "float16",
        "USE_TEXTURES": spec.uses_textures(),
        "SCENE_SDF": q.scene_sdf,
    }
    if opts["INTERSECT"] == "march":
        opts["NORMAL_METHOD"] = q.normal_method
    if opts["USE_AO"]:
        opts["AO_METHOD"] = q.ao_method
    opts.update(bug_options(spec.active_bugs(), "chart"))
    return opts


def chart_source(spec: ChartSpec) -> ComposedSource:
    return compose("chart_main.glsl", chart_options(spec))


def display_source(spec: ChartSpec) -> ComposedSource:
    opts = {"TONEMAP": spec.tonemap.replace("-", "_"), "TRANSPARENT": spec.transparent}
    opts.update(bug_options(spec.active_bugs(), "display"))
    return compose("display_main.glsl", opts)


def chart_uniforms(spec: ChartSpec, cam: camera_mod.Camera) -> dict:
    q = spec.quality_settings()
    directional = [l for l in spec.lights if l.kind == "directional"]
    point = [l for l in spec.lights if l.kind == "point"]
    scene_size = max(spec.rows, spec.cols) * spec.spacing + 2 * spec.sphere_radius
    u = {
        **cam.uniforms(),
        "u_grid": (spec.cols, spec.rows),
        "u_radius": spec.sphere_radius,
        "u_spacing": spec.spacing,
        "u_ground_y": camera_mod.ground_height(spec),
        "u_roughness_range": spec.roughness,
        "u_metallic_range": spec.metallic,
        "u_row_base_color": spec.row_base_colors(),
        "u_ground_color": spec.ground_color,
        "u_ground_roughness": spec.ground_roughness,
        "u_spp": spec.spp,
        "u_march_steps": q.march_steps,
        "u_march_far": float(np.linalg.norm(cam.position)) + 4.0 * scene_size,
        "u_hit_scale": q.hit_scale,
        "u_hit_epsilon": q.hit_epsilon,
        "u_shadow_steps": q.shadow_steps,
        "u_shadow_far": 2.0 * scene_size,
        "u_ao_taps": q.ao_taps,
        "u_ao_radius": 0.5 * spec.sphere_radius,
        "u_env_intensity": spec.env_intensity,
    }
    if directional:
        u["u_dir_light_direction"] = [l.direction for l in directional]
        u["u_dir_light_illuminance"] = [tuple(c * l.intensity for c in l.color) for l in directional]
        u["u_dir_light_angular_radius"] = [float(np.radians(l.angular_radius_deg)) for l in directional]
    if point:
        u["u_point_light_position"] = [l.position for l in point]
        u["u_point_light_intensity"] = [tuple(c * l.intensity for c in l.color) for l in point]
        u["u_point_light_range"] = [l.range for l in point]
    return u


@dataclass
class RenderResult:
    hdr: np.ndarray          # (H, W, 3) float32 linear radiance, before exposure
    alpha: np.ndarray        # (H, W) coverage
    image: np.ndarray        # (H, W, 4) uint8 display image (sRGB)
    aov: dict                # normal, depth, row, col, roughness, metallic, ndotv
    camera: camera_mod.Camera
    chart_source: ComposedSource
    timings: dict = field(default_factory=dict)


class Renderer:
    """Renders specs on one context; programs, LUTs and IBL bakes are reused across renders."""

    def __init__(self, ctx: moderngl.Context, cache: ArrayCache | None = None, tile: int | None = None):
        self.ctx = ctx
        self.programs = ProgramCache(ctx)
        self.cache = cache or ArrayCache()
        self.baker = IBLBaker(ctx, self.programs, self.cache)
        # Tiles never exceed what the context can render into; images larger than that are tiled.
        # Tile edges are whole multiples of 4, so every tile starts on the 4x4 pixel blocks of the
        # untiled render: llvmpipe takes some sampling decisions (cube-map faces) per block, and
        # tiles at other offsets changed ~1 % of IBL pixels by an ulp (found by `sdfpbr stress`).
        with ctx:
            limit = min(tile or TILE, ctx.info["GL_MAX_TEXTURE_SIZE"], *ctx.info["GL_MAX_VIEWPORT_DIMS"])
        self.tile = max(4, limit // 4 * 4)

    def render(self, spec: ChartSpec, aovs: bool = True) -> RenderResult:
        """aovs=False skips reading back the AOV targets (28 bytes a pixel): result.aov is empty."""
        with self.ctx:   # make this context current: a process may hold EGL and OSMesa ones
            return self._render(spec, aovs)

    def _render(self, spec: ChartSpec, aovs: bool = True) -> RenderResult:
        ctx = self.ctx
        t0 = time.perf_counter()
        timings = {}
        cam = camera_mod.frame_grid(spec)
        source = chart_source(spec)
        program = self.programs.fragment(source)
        display = self.programs.fragment(display_source(spec))
        timings["compile_s"] = time.perf_counter() - t0

        t1 = time.perf_counter()
        env = make_environment(ctx, spec)
        q = spec.quality_settings()
        uniforms = chart_uniforms(spec, cam)
        uniforms.update(env.uniforms)
        options = dict(source.options)
        textures = [("u_dfg", self.baker.dfg(options["BRDF_MODEL"], q, options.get("BUG_IBL_DIRECT_K", False)))]
        if spec.ibl and not options.get("BUG_FEWTAP_IBL", False):
            lighting = self.baker.lighting(env, q, options["BRDF_MODEL"])
            uniforms.update(lighting.uniforms())
            textures.append(("u_prefiltered", lighting.prefiltered))
        if env.texture is not None:
            textures.append(("u_env_map", env.texture))
        surface_maps = {}
        if options["USE_TEXTURES"]:
            from .textures import texture_set, upload
            surface_maps = upload(ctx, texture_set(spec))
            textures.extend(surface_maps.items())
        for unit, (name, tex) in enumerate(textures):
            tex.use(unit)
            uniforms[name] = unit
        set_uniforms(program, uniforms)
        display_uniforms = {"u_exposure_scale": 2.0 ** spec.exposure, "u_reinhard_white": spec.reinhard_white}
        timings["setup_s"] = time.perf_counter() - t1

        t2 = time.perf_counter()
        W, H, tile = spec.width, spec.height, self.tile
        # Tiles are read straight into the final arrays: no full-size 4-channel staging copies.
        hdr = np.empty((H, W, 3), np.float32)
        alpha = np.empty((H, W), np.float32)
        image = np.empty((H, W, 4), np.uint8)
        if aovs:
            normal = np.empty((H, W, 3), np.float32)
            depth = np.empty((H, W), np.float32)
            col = np.empty((H, W), np.int32)
            row = np.empty((H, W), np.int32)
            ndotv = np.empty((H, W), np.float32)
        half = spec.hdr_precision == "float16"
        vao = ctx.vertex_array(program, [])
        display_vao = ctx.vertex_array(display, [])
        for y0 in range(0, H, tile):
            for x0 in range(0, W, tile):
                tw, th = min(tile, W - x0), min(tile, H - y0)
                targets = [ctx.texture((tw, th), 4, dtype="f2" if half and k == 0 else "f4") for k in range(3)]
                fbo = ctx.framebuffer(color_attachments=targets)
                fbo.use()
                program["u_tile_origin"].value = (x0, y0)
                vao.render(moderngl.TRIANGLES, vertices=3)
                ldr = ctx.texture((tw, th), 4)
                ldr_fbo = ctx.framebuffer(color_attachments=[ldr])
                ldr_fbo.use()
                targets[0].use(15)
                set_uniforms(display, {**display_uniforms, "u_radiance": 15})
                display_vao.render(moderngl.TRIANGLES, vertices=3)
                # GL rows run bottom-up; tile (x0, y0) counts from the bottom-left.
                rows = slice(H - y0 - th, H - y0)
                cols = slice(x0, x0 + tw)
                radiance = np.frombuffer(targets[0].read(), np.float16 if half else np.float32).reshape(th, tw, 4)[::-1]
                hdr[rows, cols] = radiance[..., :3]
                alpha[rows, cols] = radiance[..., 3]
                if aovs:
                    normal_depth = np.frombuffer(targets[1].read(), np.float32).reshape(th, tw, 4)[::-1]
                    normal[rows, cols] = normal_depth[..., :3]
                    depth[rows, cols] = normal_depth[..., 3]
                    cells = np.frombuffer(targets[2].read(), np.float32).reshape(th, tw, 4)[::-1]
                    col[rows, cols] = np.rint(cells[..., 0])
                    row[rows, cols] = np.rint(cells[..., 1])
                    ndotv[rows, cols] = cells[..., 2]
                image[rows, cols] = np.frombuffer(ldr.read(), np.uint8).reshape(th, tw, 4)[::-1]
                for obj in (*targets, fbo, ldr, ldr_fbo):
                    obj.release()
        vao.release()
        display_vao.release()
        timings["render_s"] = time.perf_counter() - t2
        if env.texture is not None:
            env.texture.release()
        for tex in surface_maps.values():
            tex.release()

        aov = self._aovs(spec, normal, depth, col, row, ndotv) if aovs else {}
        return RenderResult(hdr, alpha, image, aov, cam, source, timings)

    @staticmethod
    def _aovs(spec: ChartSpec, normal, depth, col, row, ndotv) -> dict:
        sphere = (row >= 0) & (col >= 0)
        col[~sphere] = -1
        row[~sphere] = -1
        # Filled through the mask, so no full-size temporaries beyond the outputs.
        roughness = np.full(row.shape, np.nan, np.float32)
        metallic = np.full(row.shape, np.nan, np.float32)
        roughness[sphere] = np.asarray(spec.column_roughness(), np.float32)[col[sphere]]
        metallic[sphere] = np.asarray(spec.row_metallic(), np.float32)[row[sphere]]
        return {"normal": normal, "depth": depth, "row": row, "col": col,
                "roughness": roughness, "metallic": metallic, "ndotv": ndotv}
