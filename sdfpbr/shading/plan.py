"""The program plan: from a spec to every GL program a render runs, composed, with its options,
and the frame they draw.

This is the one place that resolves a spec: the quality preset, the BRDF model it may force,
the bugs it implies, tone-map and model names as GLSL words, which features are composed in,
which bake programs (environment cubemap, GGX prefilter, SH9 irradiance, DFG LUT, cache
copies) exist, and the frame (ChartFrame): the cell grid and camera, the floor, the page, the
cells stage's prepasses and the chart's passes' shapes. Rendering, the IBL bakes, the build cache
key, the labels, the reference and ``sdfpbr shader`` all read a plan; none decides this again.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from ..spec.bugs import BUGS, get_bug
from ..spec.chart_spec import ENV_PRESETS, QUALITY_PRESETS, ChartSpec, Quality
from ..spec.material import LOBES, exposure_axis, spec_lobes, spec_see_through
from ..spec.presets import (BRDF_MODELS, CAMERAS, INTERSECTIONS, NORMAL_METHODS, PROCEDURAL_MAPS, STAGES, TONE_MAPPERS,
                            glsl_word)
from .camera import (Camera, cell_sphere_box, frame_cell, frame_grid, ground_height, silhouettes_apart,
                     sphere_centers, sphere_discs)
from .catcher import catcher_band_pixels
from .cells import (CellGrid, SpherePrepass, cell_border_mask, cell_border_px, cell_grid,
                    cell_sphere_radius_px, prepass_frame, sphere_prepass)
from .silhouette import SILHOUETTE_RING_PAD_PX, box_triangles, silhouette_ring
from .compose import ComposedSource, OptionSchema, Value, compose
from .maps import MAP_NAMES, MAP_OPTIONS, MAPS
from .sheen import SHEEN_CENTROID_STEPS

# Which shader draws the chart: a fragment shader over each tile, or the same code as a compute
# shader (gpu/session.py chooses per renderer).
CHART_SHADERS = ("fragment", "compute")

# Every shader option, the values it may take, and the switches the bug catalog adds (off
# unless a plan sets them). The composer checks options against this, so a typo in Python or
# GLSL fails before the driver sees it.
SCHEMA = OptionSchema(
    choices={
        "BRDF_MODEL": tuple(glsl_word(m) for m in BRDF_MODELS),
        "TONEMAP": tuple(t.glsl for t in TONE_MAPPERS),
        "ENV": (*ENV_PRESETS, "file"),
        "CAMERA": CAMERAS,
        "NORMAL_METHOD": NORMAL_METHODS,
        "COPY_DIRECTION": ("to_cube", "from_cube"),
        "INTERSECT": INTERSECTIONS,
        "AO_METHOD": ("analytic", "sdf"),
        "SCENE_SDF": ("nearest_cell", "all_spheres"),
        "IBL_METHOD": ("split_sum", "sampled"),
        "IBL_DOMINANT_DIR": ("none", "frostbite", "moments"),
        "PREFILTER_KERNEL": ("cosine", "brdf"),
        "STAGE": STAGES,
        "CHART_SHADER": CHART_SHADERS,
        "EXPOSURE_AXIS": ("none", "x", "y"),
        "EDGE_PIXELS": ("inline", "skipped", "only"),
        "SPHERE_PIXELS": ("inline", "skipped", "only"),
    },
    flags=("USE_IBL", "USE_AO", "USE_SHADOWS", "HAS_GROUND", "MULTISCATTER", "TRANSPARENT",
           "USE_TEXTURES", "HALF_RADIANCE", "IBL_TWO_LOBE", "IBL_TWO_TAP", "GROUND_IBL",
           "ANALYTIC_AA", "FLOOR_PREPASS", "BOUNCE_PREPASS", "SPHERE_PREPASS", "STAGE_PROBE", "NEIGHBOUR_LIGHT",
           "BOUNCE_CACHE", "GATHER_PREPASS", "FLOOR_PARALLAX")
    + MAP_OPTIONS,
    counts=("NUM_DIR_LIGHTS", "NUM_POINT_LIGHTS", "IBL_PIXEL_SAMPLES", "BOUNCE_RAYS", "BOUNCE_MIRROR_DIRECTIONS",
            "BOUNCE_SPECULAR_SAMPLES", "HIDDEN_SKY_SAMPLES",
            "SPHERE_SAMPLES", "EDGE_SAMPLES", "BOUNCE_GATHER_SAMPLES", "SHEEN_CENTROID_MU_STEPS",
            "SHEEN_CENTROID_R_STEPS"),
    # The KHR lobes (material.py LOBES), the shadow catcher and backdrop (off unless a plan sets
    # them) and the catalog's bugs.
    switches=tuple(sorted({b.option for b in BUGS.values() if b.option.startswith("BUG_")}))
    + tuple(lobe.option for lobe in LOBES) + ("LAYERED_IBL", "SHADOW_CATCHER", "BACKDROP", "SEE_THROUGH",
       "SPHERE_PREPASS_PASS", "SHEEN_LEAN", "SUPERSAMPLE", "CELL_BORDER"),
)



def compose_program(main: str, options: Mapping[str, Value] | None = None, *,
                    root: Path | None = None) -> ComposedSource:
    """Compose ``main`` with ``options`` checked against SCHEMA."""
    return compose(main, options, SCHEMA, root=root)


# ---- resolving a spec --------------------------------------------------------------------

def quality(spec: ChartSpec) -> Quality:
    return QUALITY_PRESETS[spec.quality]


def brdf_model(spec: ChartSpec) -> str:
    """The BRDF the chart shades with: the spec's, unless its quality preset forces one."""
    return quality(spec).brdf or spec.brdf


def active_bugs(spec: ChartSpec) -> tuple[str, ...]:
    """The spec's bugs plus those its quality preset takes on purpose (seed002)."""
    implied = quality(spec).implied_bugs
    return spec.bugs + tuple(b for b in implied if b not in spec.bugs)


def bug_options(spec: ChartSpec, program: str) -> dict:
    """The compile options the spec's bugs set in one program ('chart' or 'display')."""
    out = {}
    for name in active_bugs(spec):
        bug = get_bug(name)
        if bug.program == program:
            out[bug.option] = bug.value
    return out


def env_option(spec: ChartSpec) -> str:
    return spec.env if spec.env in ENV_PRESETS else "file"


def uses_analytic_intersection(spec: ChartSpec) -> bool:
    forced = quality(spec).intersect
    return forced == "analytic" if forced else spec.intersect in ("auto", "analytic")


# ---- the frame -----------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class ChartFrame:
    """A chart's scene as its image frames it, resolved once from its spec (chart_frame): the
    quality preset and BRDF model, the stage, the cells on the image and the camera, the floor,
    the spheres' discs, the page (alpha, cell borders, the shadow catcher's fade) and the cells
    stage's prepasses. The options, the renderer, the prepasses, the labels and the reference read
    it; none derives these from the spec again."""
    spec: ChartSpec               # the scene's own values: lights, colours, sizes
    quality: Quality              # its quality preset
    brdf_model: str               # spec value ('gltf', 'schlick-ggx') after the preset
    env: str                      # ENV option: a preset name or 'file'
    sun_direction: tuple[float, float, float]   # the sky's sun: the first directional light's, else DEFAULT_SUN's
    stage: str                    # 'cells' or 'shared'
    grid: CellGrid                # the image's rows x cols cells (either stage: borders, exposure axis)
    camera: Camera                # every cell's (cells stage) or the grid's
    ground_y: float               # the floor's height
    sphere_centers: np.ndarray    # (rows, cols, 3) the spheres' world positions as the shared stage places them
                                  # (on the cells stage each cell sees its own at the origin)
    sphere_discs: tuple[np.ndarray, np.ndarray]   # the spheres on the image: (rows, cols, 2) centres, radii, px
    sphere_radius_px: float       # about how many pixels the smallest sphere's radius spans
    silhouettes_apart: bool       # no two spheres within a pixel of each other: the analytic edge needs it
    has_alpha: bool               # coverage and a shadow catcher instead of a background and a floor
    shadow_catcher: bool          # and a floor: it keeps only the light its spheres take away
    cell_border: int              # px of page colour round each cell (0: none)
    exposure_axis: str | None     # 'x' or 'y' where exposure is an axis
    # cells stage: the prepasses' origin and size (prepass_frame)
    prepass: tuple[tuple[int, int], tuple[int, int]] | None = None
    sphere_box: tuple[int, int, int, int] | None = None            # cells stage: a cell's pixels near its sphere
    catcher_band: tuple[float, float, float, float] | None = None  # cells stage with a catcher: its fade bands, px

    def border_mask(self, rows: slice = slice(None)) -> np.ndarray:
        """(rows, width) bool over ``rows`` of the image: the pixels the cell borders cover."""
        return cell_border_mask(self.grid, self.cell_border, self.spec.width, self.spec.height, rows)


# The sky environment's sun where the chart has no directional light (normalised below).
DEFAULT_SUN = (0.55, 0.6, 0.58)


def sun_direction(spec: ChartSpec) -> tuple[float, float, float]:
    """The sky's sun follows the chart's first directional light, so its highlight and its
    light agree; else DEFAULT_SUN."""
    for light in spec.lights:
        if light.kind == "directional":
            return tuple(light.direction)
    return tuple(float(c) for c in np.array(DEFAULT_SUN) / np.linalg.norm(DEFAULT_SUN))


def chart_frame(spec: ChartSpec) -> ChartFrame:
    """``spec``'s frame. A render with alpha (a transparent image, or one the display pass lays
    onto a backdrop colour) renders coverage and a shadow catcher instead of a background and a
    floor; an opaque cells-stage image frames its cells in the page colour."""
    grid = cell_grid(spec)
    alpha = spec.transparent or bool(spec.backdrop)
    catcher = alpha and spec.ground
    cells = spec.stage == "cells"
    common = dict(spec=spec, quality=quality(spec), brdf_model=brdf_model(spec), env=env_option(spec),
                  sun_direction=sun_direction(spec),
                  stage=spec.stage, grid=grid, ground_y=ground_height(spec), has_alpha=alpha, shadow_catcher=catcher,
                  cell_border=cell_border_px(grid, cells and spec.cell_borders and not alpha),
                  exposure_axis=exposure_axis(spec), sphere_centers=sphere_centers(spec))
    if not cells:
        cam = frame_grid(spec)
        centers, radii = sphere_discs(cam, common["sphere_centers"], spec.sphere_radius)
        return ChartFrame(**common, camera=cam, sphere_discs=(centers, radii), sphere_radius_px=float(radii.min()),
                          silhouettes_apart=silhouettes_apart(centers, radii))
    # Every cell sees its sphere at its own origin alike: the one disc, shifted to each cell.
    cam = frame_cell(spec, (grid.cell_width, grid.cell_height))
    (x, y), scale = (v[0] for v in cam.project(np.zeros((1, 3))))
    left = grid.left + np.arange(spec.cols) * grid.cell_width
    top = grid.top + np.arange(spec.rows) * grid.cell_height
    centers = np.stack(np.broadcast_arrays(left[None, :] + x, top[:, None] + y), axis=-1)
    radii = np.full((spec.rows, spec.cols), spec.sphere_radius * scale)
    return ChartFrame(**common, camera=cam, sphere_discs=(centers, radii),
                      sphere_radius_px=cell_sphere_radius_px(grid, spec.camera_distance_scale),
                      silhouettes_apart=True, prepass=prepass_frame(grid, spec.width, spec.height),
                      sphere_box=cell_sphere_box(cam, spec.sphere_radius),
                      catcher_band=catcher_band_pixels(spec, grid) if catcher else None)


def bounce_step(frame: ChartFrame) -> int:
    """Cell pixels between the bounce prepass's texels (stage_bounce_main.glsl): the preset's
    bounce_texels per sphere radius. 1: the bounce is shaded per pixel (no prepass), where the
    sphere is too small for a coarser grid to save anything."""
    q = frame.quality
    if q.bounce_texels <= 0:
        return 1
    return max(1, round(frame.sphere_radius_px / q.bounce_texels))


def sphere_samples(frame: ChartFrame) -> int:
    """Points per pixel edge a chart averages inside a sphere's silhouette (the cells stage's
    sphere prepass, or the chart where it shades the sphere): more where the spheres are small,
    as the preset's sphere_samples_radius says."""
    q = frame.quality
    if q.sphere_samples_radius <= 0:
        return 1
    return max(1, min(4, round(q.sphere_samples_radius / max(frame.sphere_radius_px, 1e-6))))


def texture_maps(spec: ChartSpec) -> dict[str, bool]:
    """Which maps (shading.maps) the chart composes in: those its procedural set bakes (a PNG
    replacing its part of it) and the PNGs the spec names (a base-colour texture alone adds no
    rivets); for a glTF asset, those any material has."""
    if spec.gltf:   # the asset's own textures, one layer per cell (gpu.textures)
        return spec.gltf_maps().has_textures
    baked = PROCEDURAL_MAPS.get(spec.textures, ())
    given = {"base": spec.base_color_texture, "orm": spec.orm_texture, "normal": spec.normal_texture}
    return {name: name in baked or bool(given.get(name)) for name in MAP_NAMES}


# A pass of the chart's own (its edge pass, its sphere pass) costs a program: its link and
# llvmpipe's code for it at its first draw, ~15-30 ms here; it saves per pixel of every draw:
# the edge's second ray ~40 ns (the 1024² default 168 -> 128 ms), a sphere shaded for each floor
# pixel ~150 ns (the 1024² lobes scene 401-431 -> 219-233 ms with both passes). Below these
# sizes one render does not earn the program back (a 512² chart's first render was 15-25 ms
# slower with the edge pass, its later ones 5-10 ms faster).
EDGE_PASS_MIN_PIXELS = 500_000
SPHERE_PASS_MIN_PIXELS = 200_000


def chart_options(spec: ChartSpec, passes: bool | None = None) -> dict:
    """The chart program's options: every feature the spec leaves out is absent from the
    composed source. ``passes``: as render_plan takes it."""
    return _chart_options(chart_frame(spec), passes)[0]


def _chart_options(frame: ChartFrame,
                   passes: bool | None = None) -> tuple[dict, SpherePrepass | None, tuple[bool, bool]]:
    """chart_options of ``frame``'s spec, the sphere prepass's layout where the options use one
    (worked out once: the render needs it too), and whether the chart has an edge pass and a
    sphere pass."""
    spec, q = frame.spec, frame.quality
    directional = sum(1 for light in spec.lights if light.kind == "directional")
    point = sum(1 for light in spec.lights if light.kind == "point")
    opts = {
        "BRDF_MODEL": glsl_word(frame.brdf_model),
        "ENV": frame.env,
        "CAMERA": spec.camera,
        "INTERSECT": "analytic" if uses_analytic_intersection(spec) else "march",
        "HAS_GROUND": spec.ground,
        "USE_IBL": spec.ibl,
        "USE_AO": spec.ibl and spec.ao,
        # The key light (the first directional light) casts shadows onto the ground; on the
        # cells stage point lights do too.
        "USE_SHADOWS": spec.shadows and spec.ground and (directional > 0 or (point > 0 and frame.stage == "cells")),
        "MULTISCATTER": spec.multiscatter,
        "TRANSPARENT": frame.has_alpha,
        "SHADOW_CATCHER": frame.shadow_catcher,
        "NUM_DIR_LIGHTS": directional,
        "NUM_POINT_LIGHTS": point,
        # A supersampled pixel's samples may add up over several draws (gpu/render.py), which a
        # half-float target would round at each and could overflow: float32 there.
        "HALF_RADIANCE": spec.hdr_precision == "float16" and spec.spp == 1,
        "USE_TEXTURES": spec.uses_textures(),
        # Some sphere shows what lies behind it (glTF alpha modes).
        "SEE_THROUGH": spec_see_through(spec),
        "SCENE_SDF": q.scene_sdf,
        "STAGE": frame.stage,
        "CHART_SHADER": "fragment",   # RenderPlan.chart_compute is the compute variant
    }
    used = spec_lobes(spec)
    for lobe in sorted(LOBES, key=lambda lobe: lobe.name):   # only the lobes some cell uses
        if lobe.name in used:
            opts[lobe.option] = True
    if opts["INTERSECT"] == "march":
        opts["NORMAL_METHOD"] = q.normal_method
    if opts["USE_TEXTURES"]:   # read by textures.glsl
        present = texture_maps(spec)
        opts.update({m.option: present[m.name] for m in MAPS})
    # The cells stage's floor shaded once per cell pixel (stage_floor_main.glsl).
    opts["FLOOR_PREPASS"] = opts["STAGE"] == "cells" and spec.ground and q.floor_prepass
    # One ray per pixel with the silhouette's exact coverage (edge_coverage.glsl): one sphere
    # near each pixel (the cells stage's own, the shared stage's nearest), intersected in
    # closed form.
    one_ray = spec.spp == 1 and opts["INTERSECT"] == "analytic"   # a pixel's one ray, in closed form
    opts["ANALYTIC_AA"] = (spec.antialias and one_ray
                           and (opts["STAGE"] == "cells" or opts["SCENE_SDF"] == "nearest_cell")
                           and frame.silhouettes_apart)
    # Rays beyond the pixel's centre (chart_main.glsl), composed in only where there are some.
    opts["SUPERSAMPLE"] = spec.spp > 1
    opts["BOUNCE_PREPASS"] = False
    opts["BOUNCE_SPECULAR_SAMPLES"] = 0
    if opts["STAGE"] == "cells" and opts["HAS_GROUND"] and opts["USE_AO"]:   # read by stage_bounce.glsl
        opts["BOUNCE_RAYS"] = q.bounce_rays
        opts["BOUNCE_SPECULAR_SAMPLES"] = max(q.bounce_specular_samples, 1)
        # The sphere's bounce on a coarser grid beside the floor prepass (stage_bounce_main.glsl).
        opts["BOUNCE_PREPASS"] = opts["FLOOR_PREPASS"] and bounce_step(frame) > 1
    if opts["USE_AO"]:
        opts["AO_METHOD"] = q.ao_method
        if opts["STAGE"] == "cells":   # read by ao.glsl: the sky a sphere hides from its floor
            opts["HIDDEN_SKY_SAMPLES"] = max(q.hidden_sky_samples, 1)
    opts.update(bug_options(spec, "chart"))
    # The spheres' IBL sees the stage: a probe of the environment above and the lit floor below
    # (stage_probe_main.glsl), prefiltered like the environment. Not under the few-tap bug,
    # which reads the environment itself.
    opts["STAGE_PROBE"] = opts["HAS_GROUND"] and opts["USE_IBL"] and not opts.get("BUG_FEWTAP_IBL", False)
    # A smooth sphere's mirror image of the probe on its floor (stage_bounce.glsl), in place of
    # the bounce rays' share of its reflection (shade.glsl).
    opts["BOUNCE_MIRROR_DIRECTIONS"] = (q.bounce_mirror_directions if "BOUNCE_RAYS" in opts and opts["STAGE_PROBE"]
                                        else 0)
    # A cells-stage sphere's own light back from its floor, and on to the floor again, one
    # round trip a draw of the bounce cache (bounce_cache.glsl): the probe's floor is every
    # cell's, without the cell's bounce.
    opts["BOUNCE_CACHE"] = ("BOUNCE_RAYS" in opts and opts["STAGE_PROBE"] and q.bounce_iterations > 0
                            and not opts.get("BUG_FEWTAP_IBL", False))
    if opts["BOUNCE_CACHE"]:
        opts["BOUNCE_GATHER_SAMPLES"] = max(q.bounce_gather_samples, 1)
    # ... which the chart's sphere points read from a prepass on the bounce prepass's grid
    # (stage_gather_main.glsl), where there is one.
    opts["GATHER_PREPASS"] = opts["BOUNCE_CACHE"] and opts["BOUNCE_PREPASS"]
    # The floor seen from each sphere point, not from the centre the probe sees it from
    # (floor_parallax.glsl): a table over the normal, baked from the probe.
    opts["FLOOR_PARALLAX"] = q.floor_parallax and opts["STAGE"] == "cells" and opts["STAGE_PROBE"]
    # The shared stage's neighbours give back their own light where the analytic AO takes the
    # sky away (neighbours.glsl); on the cells stage a sphere has none.
    opts["NEIGHBOUR_LIGHT"] = (q.neighbour_light and opts["STAGE"] == "shared" and opts["USE_AO"]
                               and opts.get("AO_METHOD") == "analytic" and not opts.get("BUG_FEWTAP_IBL", False))
    # Each slot's sphere shaded once per cell pixel as a dielectric and as a metal, and mixed
    # by each cell's metallic (stage_sphere_main.glsl): the chart's rays (the centre's, or the
    # analytic edge's covered part's), opaque, where cells share all but their metallic (cells.py). A map's metallic
    # scales the cell's (m_factor m_map), and the shading is linear in it, so a textured slot
    # is shaded at m_map and at 0 and mixed by m_factor alike; not a glTF asset's, whose maps
    # are each cell's own (the material table does not tell them apart). The few-tap bug's
    # shading is not linear in metallic (its f0 clamp, (1 - F)(1 - metallic)).
    layout = (sphere_prepass(spec, frame.prepass) if one_ray and opts["STAGE"] == "cells" and q.sphere_prepass
              and not opts["SEE_THROUGH"] and not (opts["USE_TEXTURES"] and spec.gltf)
              and not opts.get("BUG_FEWTAP_IBL", False) else None)
    opts["SPHERE_PREPASS"] = layout is not None
    # Passes of the chart's own, each over only the pixels it concerns, since a software
    # rasterizer runs both sides of a branch (the compute variant, a GPU's, draws inline):
    # the silhouettes' pixels over a ring round each one (RenderPlan.edge_pass), and without
    # the prepass the cells stage's spheres' pixels over each sphere's box (sphere_pass), so
    # that the floor's pixels do not shade a sphere. Where a pixel takes more than one ray (no
    # analytic edge) the chart draws them inline. No sphere pass on the shared stage: there it
    # measured slower (512²: the pass 124-150 ms, against 100-130 for the spheres' shading over
    # the whole image inline), its shading's loops ending early where no sphere is.
    pixels = spec.width * spec.height
    edge_pass = opts["ANALYTIC_AA"] and (pixels >= EDGE_PASS_MIN_PIXELS if passes is None else passes)
    sphere_pass = (opts["ANALYTIC_AA"] and opts["STAGE"] == "cells" and not opts["SPHERE_PREPASS"]
                   and (pixels >= SPHERE_PASS_MIN_PIXELS if passes is None else passes))
    if opts["ANALYTIC_AA"]:   # the chart pass leaves the edge's pixels to whichever pass draws them
        opts["EDGE_PIXELS"] = "skipped" if edge_pass or sphere_pass else "inline"
    opts["SPHERE_PIXELS"] = "skipped" if sphere_pass else "inline"
    # Small spheres average points of the pixel box (the prepass's, or the chart's own where it
    # shades the sphere); a textured sphere keeps one: its maps are filtered by the footprint.
    if opts["ANALYTIC_AA"]:
        opts["SPHERE_SAMPLES"] = 1 if opts["USE_TEXTURES"] else sphere_samples(frame)
        opts["EDGE_SAMPLES"] = max(1, q.edge_samples)
    if opts["USE_IBL"]:   # read by ibl.glsl and shade.glsl's call of it (not by the few-tap bug's)
        opts["IBL_METHOD"] = q.ibl_method
        opts["IBL_DOMINANT_DIR"] = q.ibl_dominant_dir
        opts["IBL_TWO_LOBE"] = q.ibl_two_lobe
        # the table was fitted through the moments lookup (oracle/lobe_fit.py)
        opts["IBL_TWO_TAP"] = q.ibl_two_lobe and q.ibl_two_tap and q.ibl_dominant_dir == "moments"
        if q.ibl_method == "sampled":
            opts["IBL_PIXEL_SAMPLES"] = max(q.ibl_pixel_samples, 1)
    # The ground reads its IBL from a view-direction table (ground_ibl.glsl) baked from the
    # prefiltered environment, which the few-tap bug does without.
    opts["GROUND_IBL"] = (opts["USE_IBL"] and spec.ground and q.ground_ibl_samples > 0
                          and not opts.get("BUG_FEWTAP_IBL", False))
    # The sheen and clearcoat layers over the spheres' environment light (lobes_ibl.glsl).
    if opts["USE_IBL"] and not opts.get("BUG_FEWTAP_IBL", False) and (opts.get("SHEEN") or opts.get("CLEARCOAT")):
        opts["LAYERED_IBL"] = True
        # The sheen's light read along its lobe's mean direction, not N (shading.sheen).
        if opts.get("SHEEN") and q.sheen_lean:
            opts["SHEEN_LEAN"] = True
            opts["SHEEN_CENTROID_MU_STEPS"], opts["SHEEN_CENTROID_R_STEPS"] = SHEEN_CENTROID_STEPS
    return opts, layout, (edge_pass, sphere_pass)


def display_options(spec: ChartSpec) -> dict:
    """The display program's options."""
    return _display_options(chart_frame(spec))


def _display_options(frame: ChartFrame) -> dict:
    spec = frame.spec
    opts = {"TONEMAP": glsl_word(spec.tonemap), "TRANSPARENT": frame.has_alpha, "BACKDROP": bool(spec.backdrop),
            "EXPOSURE_AXIS": frame.exposure_axis or "none", "CELL_BORDER": frame.cell_border > 0}
    opts.update(bug_options(spec, "display"))
    return opts


# ---- the plan ------------------------------------------------------------------------------

@dataclass(frozen=True)
class IBLPlan:
    """The environment bakes: cubemap from the env function, GGX prefilter, SH9 irradiance,
    and the copies that move baked levels to and from the disk cache."""
    env_bake: ComposedSource
    prefilter: ComposedSource
    irradiance: ComposedSource
    copy_to_cube: ComposedSource
    copy_from_cube: ComposedSource
    env_bake_size: int
    size: int                     # prefiltered cube edge
    samples: int                  # prefilter samples per texel
    sh_size: int                  # cube edge the SH projection reads
    stage_probe: ComposedSource | None = None   # STAGE_PROBE: the stage from a sphere's or the grid's centre
    levels: int = 0               # prefiltered levels, lod = r (levels - 1); 0: down to 4 x 4
    ground_table: ComposedSource | None = None  # the ground's IBL per view direction (GROUND_IBL)
    ground_table_size: int = 0    # its edge in texels
    turn_probe: ComposedSource | None = None    # with a stage probe: a light orbit's probe from the first frame's
    floor_parallax: ComposedSource | None = None   # FLOOR_PARALLAX: the table's bake from the probe
    floor_parallax_size: int = 0                   # its cube's edge in texels
    floor_parallax_samples: int = 0                # directions per texel

    def sources(self) -> list[ComposedSource]:
        out = [self.env_bake, self.prefilter, self.irradiance, self.copy_to_cube, self.copy_from_cube]
        return out + [s for s in (self.stage_probe, self.ground_table, self.turn_probe, self.floor_parallax)
                      if s is not None]


# The programs of a frame, in the order they draw (RenderPlan.frame_programs).
FRAME_PROGRAMS = ("floor-prepass", "bounce-cache", "bounce-prepass", "gather-prepass", "sphere-prepass", "chart",
                  "chart-spheres", "chart-edges", "display")


@dataclass(frozen=True, eq=False)
class GridShapes:
    """Triangles given in one instance's frame (GL pixels, y up; three a triangle), drawn
    ``instances`` times: instance i at origin + (i % per_row, i // per_row) * step in the image
    (grid_instances_vert.glsl)."""
    triangles: np.ndarray         # float32 (n, 2)
    instances: int
    origin: tuple[int, int] = (0, 0)
    step: tuple[int, int] = (0, 0)
    per_row: int = 1


def _in_each_cell(frame: ChartFrame, triangles: np.ndarray) -> GridShapes:
    """A cell's triangles, once in each cell of ``frame``'s grid."""
    grid = frame.grid
    return GridShapes(triangles, grid.rows * grid.cols, grid.uniforms(frame.spec.height)["u_grid_origin"],
                      (grid.cell_width, grid.cell_height), grid.cols)


def edge_rings(frame: ChartFrame, pad: float = SILHOUETTE_RING_PAD_PX) -> GridShapes:
    """The edge pass's rings, ``pad`` px to either side of each silhouette: on the cells stage
    one round a cell's sphere, drawn in every cell (each sees its sphere alike); on the shared
    stage one round each sphere, in the image's frame."""
    spec = frame.spec
    if frame.stage == "cells":
        return _in_each_cell(frame, silhouette_ring(frame.camera, np.zeros((1, 3)), spec.sphere_radius, pad))
    return GridShapes(silhouette_ring(frame.camera, frame.sphere_centers.reshape(-1, 3), spec.sphere_radius, pad), 1)


def sphere_boxes(frame: ChartFrame, pad: float = SILHOUETTE_RING_PAD_PX) -> GridShapes:
    """The cells stage's sphere pass's box round each cell's sphere, ``pad`` px beyond its
    silhouette."""
    return _in_each_cell(frame, box_triangles(cell_sphere_box(frame.camera, frame.spec.sphere_radius, pad)))


@dataclass(frozen=True)
class RenderPlan:
    """Every program a chart render runs, composed, the sizes its bakes use, and its frame:
    what a render needs, resolved once."""
    frame: ChartFrame
    vertex: ComposedSource
    chart: ComposedSource
    display: ComposedSource
    dfg: ComposedSource
    dfg_size: int
    dfg_samples: int
    ibl: IBLPlan | None           # None: no prefiltered environment (no IBL, or the few-tap bug)
    floor_prepass: ComposedSource | None = None   # FLOOR_PREPASS: the cells stage's floor, once per cell pixel
    bounce_cache: ComposedSource | None = None  # BOUNCE_CACHE: one round trip sphere -> floor, a draw
    bounce_iterations: int = 0                  # its draws
    bounce_cache_tile: int = 0                  # its texels a side per cell
    bounce_prepass: ComposedSource | None = None  # BOUNCE_PREPASS: each sphere's bounce on its floor, coarser
    gather_prepass: ComposedSource | None = None  # GATHER_PREPASS: each sphere's light back from the cache, as coarse
    sphere_prepass: ComposedSource | None = None  # SPHERE_PREPASS: each slot's sphere, once per cell pixel
    sphere_layout: SpherePrepass | None = None    # and its slots and tiles (cells.py)
    bounce_step: int = 1                        # cell pixels between the bounce prepass's texels
    edge_pass: ComposedSource | None = None     # EDGE_PIXELS: the chart's silhouette pixels, drawn
                                                # over rings round them
    sphere_pass: ComposedSource | None = None   # SPHERE_PIXELS: its spheres' pixels, over their boxes
    instances_vertex: ComposedSource | None = None   # places those rings and boxes (a cell's, once per cell)

    @property
    def spec(self) -> ChartSpec:
        return self.frame.spec

    @property
    def quality(self) -> Quality:
        return self.frame.quality

    @property
    def options(self) -> dict:
        return dict(self.chart.options)

    @property
    def glint_share(self) -> float:
        """The share of its pixel's width one shading point inside a sphere stands for: a
        light's highlight spreads over it (shade.glsl's g_glint_share, which chart_main.glsl
        and stage_sphere_main.glsl set where they average points). 1 / sqrt(spp) supersampled,
        1 / n where a small sphere's pixel averages n x n points, else 1."""
        options = self.options
        if options.get("SUPERSAMPLE"):
            return self.spec.spp ** -0.5
        if options.get("ANALYTIC_AA"):
            return 1.0 / options.get("SPHERE_SAMPLES", 1)
        return 1.0

    @property
    def chart_compute(self) -> ComposedSource:
        """The chart program as a compute shader (session.py picks which one draws), composed
        on first use: a software rasterizer never runs it (7 ms of a cold start saved). It
        draws the silhouettes' pixels itself: a GPU's branch skips the edge's work elsewhere."""
        options = {**self.options, "CHART_SHADER": "compute", "SPHERE_PIXELS": "inline"}
        if "EDGE_PIXELS" in options:
            options["EDGE_PIXELS"] = "inline"
        return compose_program("chart_main.glsl", options)

    # The passes' shapes are made on first use, like chart_compute: only a fragment-shader
    # render draws them (a shared stage's rings take ~6 ms at 1024², more than the plan's rest).
    @functools.cached_property
    def edge_shapes(self) -> GridShapes | None:
        """The edge pass's rings (edge_rings); None without an edge pass."""
        return edge_rings(self.frame) if self.edge_pass else None

    @functools.cached_property
    def sphere_shapes(self) -> GridShapes | None:
        """The sphere pass's boxes (sphere_boxes); None without a sphere pass."""
        return sphere_boxes(self.frame) if self.sphere_pass else None

    def frame_programs(self) -> dict[str, ComposedSource]:
        """The programs each frame runs, by the names `sdfpbr shader --program` takes
        (FRAME_PROGRAMS, in their order): the cells stage's prepasses where the plan has them, the
        chart, its sphere and edge passes where it has them, the display."""
        programs = dict(zip(FRAME_PROGRAMS, (self.floor_prepass, self.bounce_cache, self.bounce_prepass,
                                             self.gather_prepass, self.sphere_prepass, self.chart,
                                             self.sphere_pass, self.edge_pass, self.display)))
        return {name: source for name, source in programs.items() if source is not None}

    def sources(self) -> list[ComposedSource]:
        """Every composed program, for cache keys."""
        out = [self.vertex, self.chart, self.display, self.dfg]
        out += [s for s in (self.chart_compute, self.floor_prepass, self.bounce_cache, self.bounce_prepass,
                            self.gather_prepass, self.sphere_prepass,
                            self.sphere_pass, self.edge_pass, self.instances_vertex) if s]
        return out + (self.ibl.sources() if self.ibl else [])


def _ibl_plan(spec: ChartSpec, q: Quality, chart: dict) -> IBLPlan:
    bake = {"ENV": chart["ENV"], "BRDF_MODEL": chart["BRDF_MODEL"]}
    probe = _stage_probe(chart)
    return IBLPlan(env_bake=compose_program("bake_env_main.glsl", bake),
                   prefilter=compose_program("prefilter_main.glsl", {**bake, "PREFILTER_KERNEL": prefilter_kernel(q)}),
                   irradiance=compose_program("sh_main.glsl"),
                   copy_to_cube=compose_program("copy_cube_main.glsl", {"COPY_DIRECTION": "to_cube"}),
                   copy_from_cube=compose_program("copy_cube_main.glsl", {"COPY_DIRECTION": "from_cube"}),
                   env_bake_size=q.env_bake_size, size=q.ibl_size, samples=q.ibl_samples, sh_size=q.sh_size,
                   stage_probe=probe, levels=prefilter_levels(q),
                   turn_probe=compose_program("turn_probe_main.glsl") if probe else None,
                   ground_table=_ground_table(q, chart), ground_table_size=q.ground_ibl_size,
                   floor_parallax=compose_program("floor_parallax_main.glsl") if chart.get("FLOOR_PARALLAX") else None,
                   floor_parallax_size=q.floor_parallax_size, floor_parallax_samples=q.floor_parallax_samples)


def prefilter_kernel(q: Quality) -> str:
    """The prefilter's weight (prefilter_main.glsl): the split sum reads the levels as whole
    specular lobes ("brdf"); the sampled path filters samples with them and reads r = 1 as
    the irradiance, which needs the plain GGX kernel ("cosine")."""
    return "cosine" if q.ibl_method == "sampled" else "brdf"


def prefilter_levels(q: Quality) -> int:
    """Prefiltered levels, lod = r (levels - 1). The split sum goes down to 4 x 4 (only the
    roughest lobes read it); the sampled path also reads the r = 1 level as the irradiance
    E(n) / pi, which needs 8 x 8 (bilinear reconstruction error 0.5 %, against 1.9 % at 4 x 4,
    under the test environment of tests/test_ibl_accuracy.py)."""
    smallest = 8 if q.ibl_method == "sampled" else 4
    return max(1, int(math.log2(max(q.ibl_size // smallest, 1))) + 1)


def _stage_probe(chart: dict) -> ComposedSource | None:
    """The spheres' IBL is a probe of the stage (environment + the lit floor); the floor's
    shading is the chart's, without the spheres' textures, and its shadows those of solid
    spheres (one probe for every cell: not thinned by any one sphere's alpha)."""
    if not chart["STAGE_PROBE"]:
        return None
    return compose_program("stage_probe_main.glsl", {**chart, "USE_TEXTURES": False, "SHADOW_CATCHER": False,
                                                     "SEE_THROUGH": False, "FLOOR_PARALLAX": False,
                                                     "BOUNCE_CACHE": False})


def _floor_prepass(chart: dict) -> ComposedSource | None:
    """The cells stage's floor shaded once per cell pixel: the chart's shading, without the
    spheres' textures (the floor has none)."""
    if not chart["FLOOR_PREPASS"]:
        return None
    return compose_program("stage_floor_main.glsl", {**chart, "USE_TEXTURES": False, "BOUNCE_CACHE": False})


def _bounce_prepass(chart: dict) -> ComposedSource | None:
    """Each cell's sphere's light on its floor, on a grid coarser than the pixels: the chart's
    shading, the spheres' textures included (a textured sphere bounces its texture's colour)."""
    if not chart.get("BOUNCE_PREPASS"):
        return None
    return compose_program("stage_bounce_main.glsl", {**chart, "SHADOW_CATCHER": False})


def _bounce_cache(chart: dict) -> ComposedSource | None:
    """One draw of each cell's bounce cache: the bounce prepass's shading at the cache's floor
    points, the floor's diffuse only (what it sends back up to the sphere)."""
    if not chart.get("BOUNCE_CACHE"):
        return None
    return compose_program("bounce_cache_main.glsl", {**chart, "SHADOW_CATCHER": False})


def _gather_prepass(chart: dict) -> ComposedSource | None:
    """What each cell's sphere gets back from its bounce cache, on the bounce prepass's grid."""
    if not chart.get("GATHER_PREPASS"):
        return None
    return compose_program("stage_gather_main.glsl", {**chart, "SHADOW_CATCHER": False})


def _sphere_prepass(chart: dict) -> ComposedSource | None:
    """Each slot's sphere at metallic 0 and 1, once per cell pixel: the chart's shading of it."""
    if not chart.get("SPHERE_PREPASS"):
        return None
    return compose_program("stage_sphere_main.glsl", {**chart, "SPHERE_PREPASS": False, "SPHERE_PREPASS_PASS": True})


def _edge_pass(chart: dict, edge_pass: bool) -> ComposedSource | None:
    """The chart's silhouette pixels, drawn over the chart pass (which skips them) on a ring of
    triangles round each silhouette: the chart program with only those pixels, all of them
    shaded (their first inside ray meets a sphere)."""
    if not edge_pass:
        return None
    return compose_program("chart_main.glsl", {**chart, "EDGE_PIXELS": "only", "SPHERE_PIXELS": "inline"})


def _sphere_pass(chart: dict, edge_pass: bool, sphere_pass: bool) -> ComposedSource | None:
    """The pixels whose first ray meets a sphere, drawn over the chart pass (which leaves the
    spheres' shading out) on each sphere's box: the chart program with only those pixels, and
    their edges where the chart has no edge pass (which would draw over them after it)."""
    if not sphere_pass:
        return None
    return compose_program("chart_main.glsl", {**chart, "SPHERE_PIXELS": "only",
                                               "EDGE_PIXELS": "skipped" if edge_pass else "inline"})


def _ground_table(q: Quality, chart: dict) -> ComposedSource | None:
    """The ground's IBL table bake: the ground material (never a catalogued bug, which are about
    the spheres) under the environment, IBL_PIXEL_SAMPLES filtered samples per texel."""
    if not chart.get("GROUND_IBL"):
        return None
    return compose_program("ground_ibl_main.glsl", {
        "STAGE": "shared", "SCENE_SDF": "nearest_cell", "HAS_GROUND": True, "USE_TEXTURES": False, "STAGE_PROBE": False,
        "BRDF_MODEL": chart["BRDF_MODEL"], "MULTISCATTER": chart["MULTISCATTER"],
        "IBL_METHOD": "sampled", "IBL_PIXEL_SAMPLES": q.ground_ibl_samples,
        "IBL_DOMINANT_DIR": "none", "IBL_TWO_LOBE": False, "IBL_TWO_TAP": False})


def dfg_source(brdf: str, direct_k_bug: bool = False, sheen: bool = False) -> ComposedSource:
    """The DFG LUT bake; ``direct_k_bug`` builds it with the direct-light Schlick k, ``sheen``
    with the sheen's albedo in its alpha channel."""
    opts = {"BRDF_MODEL": glsl_word(brdf)}
    if direct_k_bug:
        opts["BUG_IBL_DIRECT_K"] = True
    if sheen:
        opts["SHEEN"] = True
    return compose_program("dfg_main.glsl", opts)


def render_plan(spec: ChartSpec, passes: bool | None = None) -> RenderPlan:
    """``passes``: whether the chart draws its silhouettes' and (without the sphere prepass) its
    spheres' pixels in passes of their own, where it can (None: where the image is large
    enough to earn their programs back, EDGE_PASS_MIN_PIXELS and SPHERE_PASS_MIN_PIXELS)."""
    frame = chart_frame(spec)
    q = frame.quality
    chart, layout, (edges, spheres) = _chart_options(frame, passes)
    chart_source = compose_program("chart_main.glsl", chart)
    edge_pass, sphere_pass = _edge_pass(chart, edges), _sphere_pass(chart, edges, spheres)
    prefiltered = spec.ibl and not chart.get("BUG_FEWTAP_IBL", False)
    bounce_prepass = _bounce_prepass(chart)
    return RenderPlan(
        frame=frame,
        vertex=compose_program("fullscreen_vert.glsl"),
        chart=chart_source,
        display=compose_program("display_main.glsl", _display_options(frame)),
        dfg=dfg_source(frame.brdf_model, bool(chart.get("BUG_IBL_DIRECT_K", False)), bool(chart.get("SHEEN"))),
        dfg_size=q.dfg_size, dfg_samples=q.dfg_samples,
        ibl=_ibl_plan(spec, q, chart) if prefiltered else None,
        floor_prepass=_floor_prepass(chart), bounce_prepass=bounce_prepass, gather_prepass=_gather_prepass(chart),
        sphere_prepass=_sphere_prepass(chart),
        bounce_cache=_bounce_cache(chart), bounce_iterations=q.bounce_iterations if chart.get("BOUNCE_CACHE") else 0,
        bounce_cache_tile=q.bounce_cache_texels,
        sphere_layout=layout, bounce_step=bounce_step(frame) if bounce_prepass else 1,
        edge_pass=edge_pass, sphere_pass=sphere_pass,
        instances_vertex=compose_program("grid_instances_vert.glsl") if edge_pass or sphere_pass else None)


# ---- the reference's plan --------------------------------------------------------------------

def reference_scene(spec: ChartSpec) -> ChartSpec:
    """The scene the reference renders: ``spec`` without its catalogued bugs and with the
    default quality preset, since both only describe how the chart approximates (or gets
    wrong) the scene; a preset's forced BRDF model is one of those, so the reference shades
    with ``spec.brdf``."""
    from ..spec.chart_spec import make_spec
    return make_spec(spec, bugs=(), quality="default")


@dataclass(frozen=True)
class ReferencePlan:
    frame: ChartFrame             # the frame of reference_scene(spec)
    options: dict                 # the chart options of the scene (the reference modules
                                  # ignore those for IBL, AO, soft shadows and marching)
    vertex: ComposedSource
    integrator: ComposedSource    # reference_main: the path tracer
    aov: ComposedSource           # reference_aov_main: pixel-centre rays
    env_table: ComposedSource     # reference_env_main: the env function on an equirect grid
    display: ComposedSource       # the chart's display program for the scene

    @property
    def scene(self) -> ChartSpec:
        """reference_scene(spec)."""
        return self.frame.spec

    def sources(self) -> list[ComposedSource]:
        return [self.vertex, self.integrator, self.aov, self.env_table, self.display]


def reference_plan(spec: ChartSpec) -> ReferencePlan:
    frame = chart_frame(reference_scene(spec))
    options = _chart_options(frame)[0]
    return ReferencePlan(frame=frame, options=options,
                         vertex=compose_program("fullscreen_vert.glsl"),
                         integrator=compose_program("reference_main.glsl", options),
                         aov=compose_program("reference_aov_main.glsl", options),
                         env_table=compose_program("reference_env_main.glsl", {"ENV": options["ENV"]}),
                         display=compose_program("display_main.glsl", _display_options(frame)))
