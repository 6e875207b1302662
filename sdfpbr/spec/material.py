"""What a chart's spheres are made of: the material parameters (each written down once: name,
bounds, the value it takes off an axis, the lobe it belongs to, its axis title), the Material of
one cell, and every cell's Material from a spec.

A parameter is a range on the spec (``clearcoat = 0:1`` or one number, ``clearcoat = 0.5``);
the chart's x and y axes each name one parameter, whose values run across the columns (down
the rows): its range, inclusive, or an explicit list (``x_values``). Every other parameter
holds one value. The float64 model (sdfpbr.oracle.lobes), the chart's material table
(sdfpbr.shading.material_table) and the labels all read a cell's Material from here.
"""
from __future__ import annotations

import colorsys
import functools
from dataclasses import dataclass, fields
from typing import Callable

import numpy as np

from ..errors import SpecError
from .presets import MATERIAL_PRESETS

# Every perceptual roughness is clamped to this before alpha = r^2 (Filament's fp32 guard: alpha^2 =
# 0.045^4 stays a normal, well-conditioned float); common.glsl's define of the same name.
MIN_PERCEPTUAL_ROUGHNESS = 0.045


@dataclass(frozen=True)
class Param:
    name: str
    lo: float
    hi: float
    value: float        # what the chart uses when no axis shows the parameter (its default)
    title: str          # axis title
    help: str
    lobe: str = ""      # the lobe it belongs to ('' = the core metallic-roughness material)
    axis_only: bool = False   # read only on an axis (base_color_hue)
    axis_range: tuple[float, float] | None = None   # its range when put on an axis unset; None: (lo, hi)
    short: str = ""     # its name in running text (a chart's title); '' = the name with spaces

    @property
    def label(self) -> str:
        return self.short or self.name.replace("_", " ")

    @property
    def sweep(self) -> tuple[float, float]:
        return self.axis_range or (self.lo, self.hi)


PARAMS: tuple[Param, ...] = (
    Param("roughness", 0.0, 1.0, 0.5, "roughness r (α = r²)", "perceptual roughness"),
    Param("metallic", 0.0, 1.0, 0.0, "metallic", "metallic"),
    Param("clearcoat", 0.0, 1.0, 0.0, "clearcoat", "KHR_materials_clearcoat layer weight", "clearcoat"),
    Param("clearcoat_roughness", 0.0, 1.0, 0.0, "clearcoat roughness", "the clearcoat's perceptual roughness",
          "clearcoat"),
    Param("sheen_roughness", 0.0, 1.0, 0.5, "sheen roughness", "KHR_materials_sheen perceptual roughness", "sheen"),
    Param("ior", 1.0, 5.0, 1.5, "IOR", "KHR_materials_ior index of refraction (f0 = ((ior-1)/(ior+1))²)",
          "specular", axis_range=(1.0, 2.5), short="IOR"),
    Param("specular", 0.0, 1.0, 1.0, "specular", "KHR_materials_specular weight of the dielectric specular",
          "specular"),
    Param("emissive_strength", 0.0, 1e4, 1.0, "emissive strength", "KHR_materials_emissive_strength",
          "emission", axis_range=(0.0, 4.0)),
    # Titled as opacity: α on a chart is GGX alpha (the roughness axis's α = r²).
    Param("alpha", 0.0, 1.0, 1.0, "opacity (base-colour alpha)", "base-colour alpha: the sphere's share of its "
          "pixels over what lies behind it (alpha_mode: blend, or cut out below alpha_cutoff)", short="opacity"),
    Param("base_color_hue", 0.0, 360.0, 0.0, "base colour hue (°)",
          "hue of the base colour in degrees, on an axis only (saturation and value kept; 0.8 for a grey)",
          axis_only=True, axis_range=(0.0, 300.0), short="base colour hue"),
)
PARAM_NAMES = tuple(p.name for p in PARAMS)
# Exposure is no material parameter but can be an axis: the display pass then exposes each
# cell (floor and all) by its column's or row's EV, around the spec's exposure (± 2 EV unless
# values are given). The cells stage only: there every pixel belongs to one cell.
EXPOSURE_AXIS = Param("exposure", -40.0, 40.0, 0.0, "exposure (EV)", "exposure in EV", axis_only=True,
                      axis_range=(-2.0, 2.0))
AXIS_PARAMS = PARAM_NAMES + (EXPOSURE_AXIS.name,)
_BY_NAME = {p.name: p for p in (*PARAMS, EXPOSURE_AXIS)}

# Colour parameters of the lobes: name -> (default, lobe, help).
COLOR_PARAMS = {
    "sheen_color": ((0.0, 0.0, 0.0), "sheen", "linear KHR_materials_sheen colour (black: no sheen)"),
    "specular_color": ((1.0, 1.0, 1.0), "specular", "linear KHR_materials_specular colour (scales f0)"),
    "emissive": ((0.0, 0.0, 0.0), "emission", "linear emissive colour"),
}

# What a glTF asset's materials decide, one per cell (ChartSpec attributes): a spec that charts
# an asset and sets any of these would have it ignored, so it is refused (chart_spec), and a
# bug's visibility settings leave them to the asset (bugs.Bug.correct).
GLTF_OWNS = ("x_axis", "y_axis", "x_values", "y_values", "base_color", "base_colors", "row_materials",
             "alpha_mode", "alpha_cutoff", *PARAM_NAMES, *COLOR_PARAMS)

# glTF's alphaMode: opaque ignores alpha, mask cuts out the texels below the cutoff, blend lays
# the sphere over what lies behind it by its alpha; auto (a chart's choice) blends where a
# cell's alpha is below 1. Alpha applies to what the camera sees; the light treats every
# sphere as solid (its shadow, occlusion and bounce), in the chart and the reference alike.
ALPHA_MODES = ("auto", "opaque", "mask", "blend")

GREY_HUE_SATURATION = 0.8   # the saturation a hue axis gives a grey base colour


def param(name: str) -> Param:
    return _BY_NAME[name]


# The chart's default base colour: a saturated orange, so that a metal's tinted reflections
# read against a dielectric's coloured body under white highlights (a grey hides both).
DEFAULT_BASE_COLOR = (0.8, 0.3, 0.08)


@dataclass(frozen=True)
class Material:
    """One cell's material: glTF 2.0 metallic-roughness and the KHR lobes (linear colours)."""
    base_color: tuple[float, float, float] = DEFAULT_BASE_COLOR
    metallic: float = 0.0
    roughness: float = 0.5
    clearcoat: float = 0.0
    clearcoat_roughness: float = 0.0
    sheen_color: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sheen_roughness: float = 0.5
    ior: float = 1.5
    specular: float = 1.0
    specular_color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    emissive: tuple[float, float, float] = (0.0, 0.0, 0.0)
    emissive_strength: float = 1.0
    alpha: float = 1.0
    alpha_mode: str = "opaque"      # opaque, mask or blend (ALPHA_MODES less auto)
    alpha_cutoff: float = 0.5
    name: str = ""

    @property
    def see_through(self) -> bool:
        """Whether the camera may see past this sphere: by its alpha, or its texture's."""
        return self.alpha_mode != "opaque"

    def lobes(self) -> set[str]:
        """The lobes this material needs beyond the core (values that change nothing need none)."""
        return {lobe.name for lobe in LOBES if lobe.used(self)}


# The KHR lobes: one row each, read by everything that composes, reads or names a lobe (the
# plan's compose options, the glTF reader's factors and textures, the texture bake, the
# `--help` groups, the tests). docs/extending.md says what else a new lobe needs.

@dataclass(frozen=True)
class GltfFactor:
    """A number or colour that a glTF material's extension gives one Material field."""
    key: str                            # the extension's key ("clearcoatFactor")
    field: str                          # the Material field it sets
    default: float | tuple              # glTF's value where the key is absent (not always the chart's)
    zero_means: float | None = None     # what a 0 stands for (KHR_materials_ior: 0 is an infinite ior)


@dataclass(frozen=True)
class GltfTexture:
    """A texture that a glTF material's extension gives a lobe, and the chart's map it goes to
    (sdfpbr.shading.maps makes the map, textures.glsl reads it): one channel into a shared map
    of data, or a colour (sRGB) or tangent-space normal map of its own."""
    key: str                            # the extension's key ("clearcoatTexture")
    name: str                           # its name in a material's textures ("clearcoat")
    map: str                            # the map it goes to ("khr", "coat_normal", ...)
    kind: str = "colour"                # "channel", "colour" or "normal"
    channel: tuple[int, int] = (0, 0)   # a "channel" texture's: (its channel, the map's)
    amount_key: str | None = None       # the texture info's scale ("scale" of a normal map)


@dataclass(frozen=True)
class GltfExtension:
    name: str                           # "KHR_materials_clearcoat"
    factors: tuple[GltfFactor, ...] = ()
    textures: tuple[GltfTexture, ...] = ()


@dataclass(frozen=True)
class Lobe:
    name: str                           # its word in specs, docs and Material.lobes()
    option: str                         # the compose option that puts it into the chart and the reference
    used: Callable[[Material], bool]    # whether a material needs it (values that change nothing need none)
    gltf: tuple[GltfExtension, ...] = ()   # the glTF extensions it charts


LOBES: tuple[Lobe, ...] = (
    Lobe("clearcoat", "CLEARCOAT", lambda m: m.clearcoat > 0.0, (
        GltfExtension("KHR_materials_clearcoat", (
            GltfFactor("clearcoatFactor", "clearcoat", 0.0),
            GltfFactor("clearcoatRoughnessFactor", "clearcoat_roughness", 0.0)), (
            GltfTexture("clearcoatTexture", "clearcoat", "khr", "channel", (0, 0)),
            GltfTexture("clearcoatRoughnessTexture", "clearcoat_roughness", "khr", "channel", (1, 1)),
            GltfTexture("clearcoatNormalTexture", "clearcoat_normal", "coat_normal", "normal",
                        amount_key="scale"))),)),
    Lobe("sheen", "SHEEN", lambda m: max(m.sheen_color) > 0.0, (
        GltfExtension("KHR_materials_sheen", (
            GltfFactor("sheenColorFactor", "sheen_color", (0.0, 0.0, 0.0)),
            GltfFactor("sheenRoughnessFactor", "sheen_roughness", 0.0)), (
            GltfTexture("sheenColorTexture", "sheen_color", "sheen_color"),
            GltfTexture("sheenRoughnessTexture", "sheen_roughness", "khr", "channel", (3, 3)))),)),
    Lobe("specular", "KHR_SPECULAR",
         lambda m: m.ior != 1.5 or m.specular != 1.0 or m.specular_color != (1.0, 1.0, 1.0), (
        GltfExtension("KHR_materials_specular", (
            GltfFactor("specularFactor", "specular", 1.0),
            GltfFactor("specularColorFactor", "specular_color", (1.0, 1.0, 1.0))), (
            GltfTexture("specularTexture", "specular", "khr", "channel", (3, 2)),
            GltfTexture("specularColorTexture", "specular_color", "specular_color"))),
        GltfExtension("KHR_materials_ior", (GltfFactor("ior", "ior", 1.5, zero_means=1e9),)))),
    # The emissive colour and its texture are glTF 2.0's core; the lobe adds the strength.
    Lobe("emission", "EMISSION", lambda m: max(m.emissive) > 0.0 and m.emissive_strength > 0.0, (
        GltfExtension("KHR_materials_emissive_strength", (
            GltfFactor("emissiveStrength", "emissive_strength", 1.0),)),)),
)
LOBE_NAMES = tuple(lobe.name for lobe in LOBES)
LOBE_TEXTURES = tuple(t for lobe in LOBES for e in lobe.gltf for t in e.textures)


def dielectric_f0(ior, specular_color=(1.0, 1.0, 1.0)):
    """KHR_materials_ior and _specular: min(((ior - 1) / (ior + 1))^2 specular_color, 1), (..., 3)."""
    ior = np.asarray(ior, np.float64)
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2
    return np.minimum(f0[..., None] * np.asarray(specular_color, np.float64), 1.0)



MATERIAL_FIELDS = tuple(f.name for f in fields(Material) if f.name not in ("name", "alpha_mode"))


def inclusive(rng: tuple[float, float], n: int) -> list[float]:
    lo, hi = rng
    return [lo] if n == 1 else [lo + (hi - lo) * i / (n - 1) for i in range(n)]


def axis_param(spec, axis: str) -> Param:
    return param(spec.x_axis if axis == "x" else spec.y_axis)


def axis_values(spec, axis: str) -> list[float]:
    """The values along an axis ('x': across the columns, 'y': down the rows)."""
    given = spec.x_values if axis == "x" else spec.y_values
    if given:
        return list(given)
    p, n = axis_param(spec, axis), spec.cols if axis == "x" else spec.rows
    if p is EXPOSURE_AXIS:   # around the spec's exposure
        return [spec.exposure + v for v in inclusive(p.sweep, n)]
    return inclusive(getattr(spec, p.name), n)


def exposure_axis(spec) -> str | None:
    """'x' or 'y' where exposure is on an axis, else None."""
    return next((a for a in ("x", "y") if axis_param(spec, a) is EXPOSURE_AXIS), None)


def with_hue(color, hue_deg: float) -> tuple[float, float, float]:
    h, s, v = colorsys.rgb_to_hsv(*color)
    if s == 0.0:
        s = GREY_HUE_SATURATION
    return colorsys.hsv_to_rgb((hue_deg / 360.0) % 1.0, s, v)


def _per_cell(values, rows: int, cols: int, what: str) -> list[list]:
    """A list given per row (rows entries) or per cell (rows x cols, row by row)."""
    if len(values) == rows:
        return [[v] * cols for v in values]
    if len(values) == rows * cols:
        return [list(values[r * cols:(r + 1) * cols]) for r in range(rows)]
    raise SpecError(f"{what} lists {len(values)} entries for {rows} rows x {cols} columns; "
                    f"give one per row ({rows}) or one per cell ({rows * cols})")


def check_axes(spec) -> None:
    """The spec's axes are consistent: two different parameters, value lists as long as the
    grid, and every other parameter at one value."""
    if spec.x_axis == spec.y_axis:
        raise SpecError(f"x_axis and y_axis are both {spec.x_axis}; give two different parameters")
    if EXPOSURE_AXIS.name in (spec.x_axis, spec.y_axis) and (spec.stage != "cells" or spec.gltf):
        raise SpecError("exposure on an axis needs the cells stage (stage = \"cells\"), where every pixel "
                        "belongs to one cell, and no gltf")
    for axis, values, n, count in (("x", spec.x_values, spec.cols, "cols"), ("y", spec.y_values, spec.rows, "rows")):
        p = axis_param(spec, axis)
        if values and len(values) != n:
            raise SpecError(f"{axis}_values lists {len(values)} values for {n} {count}; give {n} or leave {count} out")
        for v in values:
            if not p.lo <= v <= p.hi:
                raise SpecError(f"{axis}_values: {p.name} must be in [{p.lo:g}, {p.hi:g}], got {v:g}")
    on_axis = (spec.x_axis, spec.y_axis)
    for p in PARAMS:
        lo, hi = getattr(spec, p.name)
        if p.name not in on_axis and not p.axis_only and lo != hi:
            raise SpecError(f"{p.name} {lo:g}:{hi:g} varies but neither axis shows it; give it one value "
                            f"({p.name} = {lo:g}) or put it on an axis (x_axis = \"{p.name}\")")
    for what, values in (("base_colors", spec.base_colors), ("materials", spec.row_materials)):
        if values:
            _per_cell(values, spec.rows, spec.cols, what)
    if spec.gltf:
        from .gltf import gltf_materials   # here: a chart without glTF does not import its reader
        count = len(gltf_materials(spec.gltf, spec.gltf_materials).materials)
        if count != spec.rows * spec.cols:
            raise SpecError(f"gltf charts {count} materials, one per cell: rows x cols must be {count}, "
                            f"got {spec.rows} x {spec.cols}")
        given = [n for n in ("base_color_texture", "orm_texture", "normal_texture") if getattr(spec, n)]
        if given or spec.textures != "none":
            raise SpecError(f"gltf charts the asset's own textures; {(given or ['textures'])[0]} applies to "
                            "charts without gltf")
    elif spec.gltf_materials:
        raise SpecError("gltf_materials names materials of a glTF asset; give gltf too")


def cell_materials(spec) -> list[list[Material]]:
    """Every cell's Material, row by row (row 0 at the top, column 0 at the left)."""
    rows, cols = spec.rows, spec.cols
    if spec.gltf:   # one material per cell, row by row; the axes do not apply
        from .gltf import gltf_materials
        found = [Material(**m) for m in gltf_materials(spec.gltf, spec.gltf_materials).materials]
        return [found[r * cols:(r + 1) * cols] for r in range(rows)]
    return [list(row) for row in _swept_materials(spec)]


@functools.lru_cache(maxsize=64)
def _swept_materials(spec) -> tuple[tuple[Material, ...], ...]:
    """cell_materials of a spec without glTF, which its fields alone decide (a spec is frozen):
    a render asks for them a dozen times (plan, prepasses, tables, labels), 0.2 ms each."""
    rows, cols = spec.rows, spec.cols
    if spec.row_materials:
        bases = _per_cell([MATERIAL_PRESETS[m] for m in spec.row_materials], rows, cols, "materials")
    elif spec.base_colors:
        bases = _per_cell(list(spec.base_colors), rows, cols, "base_colors")
    else:
        bases = [[spec.base_color] * cols for _ in range(rows)]
    fixed = {p.name: getattr(spec, p.name)[0] for p in PARAMS if not p.axis_only}
    fixed.update({name: getattr(spec, name) for name in COLOR_PARAMS})
    xs, ys = axis_values(spec, "x"), axis_values(spec, "y")
    out = []
    for r in range(rows):
        row = []
        for c in range(cols):
            values = {**fixed, spec.x_axis: xs[c], spec.y_axis: ys[r]}
            values.pop(EXPOSURE_AXIS.name, None)   # the display's, not the material's
            base = tuple(bases[r][c])
            hue = values.pop("base_color_hue", None)
            if "base_color_hue" in (spec.x_axis, spec.y_axis):
                base = with_hue(base, hue)
            mode = spec.alpha_mode
            if mode == "auto":
                mode = "blend" if values["alpha"] < 1.0 else "opaque"
            row.append(Material(base_color=tuple(float(x) for x in base), alpha_mode=mode,
                                alpha_cutoff=spec.alpha_cutoff, **values))
        out.append(tuple(row))
    return tuple(out)


def material_array(spec, name: str):
    """One parameter of every cell, (rows, cols) or (rows, cols, 3) for a colour, float64."""
    return np.array([[getattr(m, name) for m in row] for row in cell_materials(spec)], np.float64)


def spec_lobes(spec) -> set[str]:
    """The lobes some cell of the spec uses."""
    return set().union(*(m.lobes() for row in cell_materials(spec) for m in row))


def spec_see_through(spec) -> bool:
    """Whether the camera may see past some cell's sphere (Material.see_through)."""
    return any(m.see_through for row in cell_materials(spec) for m in row)


def displaced_defaults(base, values: dict, default_spec) -> dict:
    """Parameters the user left at their defaults follow the axes: one no axis shows any more
    takes its one value (roughness 0.5, metallic 0), one an axis now shows takes its sweep
    (clearcoat 0:1, ior 1:2.5), so ``x_axis = "clearcoat"`` alone is a chart of clearcoat. Only
    a parameter the new values put on or take off an axis moves: ``base`` stays as it is."""
    axes = (values.get("x_axis", base.x_axis), values.get("y_axis", base.y_axis))
    old_axes = (base.x_axis, base.y_axis)
    out = {}
    for p in PARAMS:
        current = getattr(base, p.name)
        if p.name in values or p.axis_only or current != getattr(default_spec, p.name):
            continue
        if (p.name in axes) == (p.name in old_axes):
            continue
        if p.name not in axes and current[0] != current[1]:
            out[p.name] = (p.value, p.value)
        elif p.name in axes and current[0] == current[1]:
            out[p.name] = p.sweep
    return out
