"""The chart spec's fields, each written down once: name, default, check, help, how it is spelled
on the command line and in a sweep. The spec class, the CLI flags, TOML keys, Python keywords,
sweep axes and the spec writers are all made from this table.

One name works everywhere: TOML key = Python keyword = flag without its dashes, and '-' and '_'
are the same in all of them. Old names keep working as aliases (``row_materials``,
``--azimuth``). ``size`` is a field of its own that sets width and height, on every surface.
"""
from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from dataclasses import fields as dataclass_fields
from pathlib import Path
from typing import Any, Callable, Mapping

from ..errors import SpecError, did_you_mean
from ..inputs import check_input
from .bugs import BUGS, get_bug
from .checks import (bool_text, boolean, choice, is_number, number, number_text, parse_color, parse_names, parse_range,
                     parse_size, quote, sequence, text, vec3)
from .material import ALPHA_MODES, AXIS_PARAMS, COLOR_PARAMS, DEFAULT_BASE_COLOR, LOBE_NAMES, PARAMS
from .presets import (BACKENDS, BRDF_MODELS, CAMERAS, DEFAULT_LIGHTS, ENV_PRESETS, HDR_PRECISIONS, INTERSECT_METHODS,
                      LIGHT_SETTINGS, MATERIAL_PRESETS, MAX_GRID, MAX_LIGHTS, MAX_SIZE, MAX_TITLE, QUALITY_PRESETS,
                      STAGES, TEXTURE_MODES, TONE_MAPPERS, TONEMAPPERS, light_from_mapping)
from .toml_file import read_toml


@dataclass(frozen=True)
class Field:
    name: str                        # TOML key = Python keyword = flag without dashes
    kind: str                        # int float bool choice text path env range color names bugs lights size
                                     # numbers colors
    default: Any
    check: Callable[[Any], Any]      # any accepted value -> the stored value; SpecError otherwise
    parse: Callable[[str], Any]      # command-line text -> a value for check
    help: str = ""
    metavar: str | None = None
    aliases: tuple[str, ...] = ()    # old or short names, accepted wherever the name is
    sweep: tuple = ()                # the values `sdfpbr sweep NAME` shows when none are given
    attrs: tuple[str, ...] = ()      # the ChartSpec attributes it sets; () means (name,)
    many: str = "values"             # what each of a list of its text values must be (sweep messages)
    bounds: tuple = ()               # (lo, hi) of a number or of a range's ends, as check enforces
    choices: tuple = ()              # the allowed words of a choice (or list of names), as check enforces
    annotation: Any = Any
    display: bool = False            # read by the display pass alone: the radiance does not change with it

    @property
    def stored(self) -> tuple[str, ...]:
        return self.attrs or (self.name,)

    @property
    def numeric(self) -> bool:
        """Its values are numbers or lists of them, so their text may start with a minus."""
        return self.kind in ("int", "float", "size", "range", "color", "colors", "numbers")

    @functools.cached_property   # read ~500 times a spec made
    def attr(self) -> str:
        """The one attribute of a stored field (every field but size)."""
        (attr,) = self.stored
        return attr

    @property
    def option_strings(self) -> tuple[str, ...]:
        return tuple("--" + n.replace("_", "-") for n in (self.name, *self.aliases))

    def from_text(self, value_text: str):
        """Command-line text -> the checked value."""
        return self.check(self.parse(value_text))

    def to_text(self, value) -> str:
        """The inverse of from_text for stored values (what spec_to_flags writes)."""
        if self.kind in ("int", "text", "path", "env", "choice"):
            return str(value)
        if self.kind == "float":
            return repr(float(value))
        if self.kind == "range":
            return ":".join(repr(float(v)) for v in value)
        if self.kind in ("color", "numbers"):
            return ",".join(repr(float(v)) for v in value)
        if self.kind == "colors":
            return ";".join(",".join(repr(float(v)) for v in c) for c in value)
        if self.kind in ("names", "bugs"):
            return ",".join(value)
        if self.kind == "size":
            return "x".join(str(v) for v in value)
        if self.kind == "lights":
            for word, lights in LIGHT_WORDS.items():
                if tuple(value) == lights:
                    return word
            raise SpecError("only lights = default or none have a flag; write other lights with spec_to_toml")
        if self.kind == "bool":
            return "true" if value else "false"
        raise AssertionError(self.kind)


LIGHT_WORDS = {"default": DEFAULT_LIGHTS, "none": ()}


# ---- checks the simple constructors do not cover -----------------------------------------------

def _range(name: str, lo: float = 0.0, hi: float = 1.0):
    """LO:HI, a [lo, hi] pair, or one number (a range of one value)."""
    def check(v):
        if isinstance(v, str):
            try:
                v = parse_range(v, name) if ":" in v else number_text(v, name)
            except SpecError:
                raise SpecError(f"{name} must be LO:HI (e.g. 0:1) or one number, got {quote(v)}") from None
        if is_number(v):
            v = (v, v)
        return tuple(number(x, name, lo, hi) for x in sequence(v, name, 2, "LO:HI, one number or a [lo, hi] pair"))
    return check


def _numbers(name: str):
    """An axis' explicit values: '0,0.5,1' or a list of numbers (checked against the axis'
    parameter by the spec)."""
    def check(v):
        if isinstance(v, str):
            v = tuple(number_text(t, name) for t in parse_names(v, ",+"))
        values = sequence(v, name, form="a list of numbers")
        if len(values) > MAX_GRID:
            raise SpecError(f"{name} lists {len(values)} values; at most {MAX_GRID}")
        return tuple(number(x, name) for x in values)
    return check


def _colors(v) -> tuple:
    if isinstance(v, str):
        v = [parse_color(t, "base_colors") for t in v.split(";")] if v.strip() else []
    values = sequence(v, "base_colors", form="a list of R,G,B colours")
    if len(values) > MAX_GRID * MAX_GRID:
        raise SpecError(f"base_colors lists {len(values)} colours; at most one per cell ({MAX_GRID * MAX_GRID})")
    return tuple(vec3(c, "base_colors", 0.0, 1.0) for c in values)


def _color(name: str):
    def check(v):
        return vec3(parse_color(v, name) if isinstance(v, str) else v, name, 0.0, 1.0)
    return check


def _backdrop(v) -> tuple:
    """'R,G,B' or [r, g, b] in sRGB; '', 'none' or [] for none."""
    if (v is None or (isinstance(v, str) and v.strip().lower() in ("", "none"))
            or (isinstance(v, (list, tuple)) and not v)):
        return ()
    return vec3(parse_color(v, "backdrop", "sRGB") if isinstance(v, str) else v, "backdrop", 0.0, 1.0)


def _materials(v) -> tuple[str, ...]:
    names = parse_names(v) if isinstance(v, str) else sequence(v, "materials", form="a list of material names")
    return tuple(choice(m, "material", tuple(MATERIAL_PRESETS)) for m in names)


def _bugs(v) -> tuple[str, ...]:
    names = parse_names(v) if isinstance(v, str) else sequence(v, "bugs", form="a list of bug names")
    return tuple(get_bug(b).name for b in names)


def _lights(v) -> tuple:
    if isinstance(v, str):
        if v not in LIGHT_WORDS:
            raise SpecError(f"lights {quote(v)} is not allowed{did_you_mean(v, LIGHT_WORDS)}; "
                            f"allowed: default, none, or a list of lights")
        return LIGHT_WORDS[v]
    given = sequence(v, "lights", form="default, none or a list of lights")
    if len(given) > MAX_LIGHTS:   # counted before any is read: a million lights are refused at once
        raise SpecError(f"at most {MAX_LIGHTS} lights, got {len(given)}")
    return tuple(light_from_mapping(m) for m in given)


ENV_FILE_SUFFIXES = (".exr", ".hdr", ".npy")   # what inputs.environment.load_env_file reads


def _env(v) -> str:
    if not isinstance(v, str) or not v:
        raise SpecError(f"env must be a preset ({', '.join(ENV_PRESETS)}) or an .exr/.hdr/.npy file, got {quote(v)}")
    if v not in ENV_PRESETS:
        path = Path(v)
        if path.suffix.lower() not in ENV_FILE_SUFFIXES:
            raise SpecError(f"env {quote(v)} is not a preset{did_you_mean(v, ENV_PRESETS)}; "
                            f"allowed: {', '.join(ENV_PRESETS)} or an .exr/.hdr/.npy file")
        check_input(path, "env file", "environment")
    return v


def _png(name: str):
    def check(v):
        text(v, f"{name} (a PNG path)")
        if v and Path(v).suffix.lower() != ".png":
            raise SpecError(f"{name} {quote(v)} is not a .png file")
        if v:
            check_input(v, name, "image")
        return v
    return check


def _gltf(v) -> str:
    text(v, "gltf (a .gltf or .glb path)")
    if not v:
        return v
    from .gltf import GLTF_SUFFIXES   # here: a chart without glTF does not import its reader
    if Path(v).suffix.lower() not in GLTF_SUFFIXES:
        raise SpecError(f"gltf {quote(v)} is not a .gltf or .glb file")
    check_input(v, "gltf", "gltf")
    return v


def _gltf_names(v) -> tuple[str, ...]:
    names = parse_names(v) if isinstance(v, str) else sequence(v, "gltf_materials", form="a list of material names")
    for n in names:
        if not isinstance(n, str) or not n:
            raise SpecError(f"gltf_materials must be material names, got {quote(n)}")
    return tuple(names)


def _size(v) -> tuple[int, int]:
    w, h = parse_size(v)   # each side named as the user wrote it: "size width", "size height"
    return (number(w, "size width", 1, MAX_SIZE, integer=True),
            number(h, "size height", 1, MAX_SIZE, integer=True))


# ---- constructors, one per kind of field -------------------------------------------------------

def _identity(t):
    return t


def _int(name, default, lo, hi, help, **kw) -> Field:
    return Field(name, "int", default, lambda v: number(v, name, lo, hi, integer=True),
                 lambda t: number_text(t, name), help, kw.pop("metavar", "N"),
                 many="whole numbers", bounds=(lo, hi), annotation=int, **kw)


def _float(name, default, lo, hi, help, **kw) -> Field:
    return Field(name, "float", default, lambda v: number(v, name, lo, hi), lambda t: number_text(t, name),
                 help, kw.pop("metavar", "X"), many="numbers", bounds=(lo, hi), annotation=float, **kw)


def _bool(name, default, help, **kw) -> Field:
    return Field(name, "bool", default, lambda v: boolean(v, name), lambda t: bool_text(t, name), help,
                 many="true or false", annotation=bool, **kw)


def _choice(name, default, choices, help, labels=None, **kw) -> Field:
    """A field that takes one of ``choices``; ``labels`` (choice -> what it is) go into the help."""
    choices = tuple(choices)
    listed = ", ".join(f"{c} ({labels[c]})" if labels else c for c in choices)
    return Field(name, "choice", default, lambda v: choice(v, name, choices), _identity,
                 f"{help}: {listed}", kw.pop("metavar", "NAME"), choices=choices, annotation=str, **kw)


def _other(kind, name, default, check, help, metavar, parse=_identity, **kw) -> Field:
    return Field(name, kind, default, check, parse, help, metavar, **kw)


FIELDS: tuple[Field, ...] = (
    _int("rows", 5, 1, MAX_GRID, "rows of spheres; metallic runs down them"),
    _int("cols", 5, 1, MAX_GRID, "columns of spheres; roughness runs across them"),
    _int("width", 1024, 1, MAX_SIZE, "render width in pixels", metavar="PX"),
    _int("height", 1024, 1, MAX_SIZE, "render height in pixels", metavar="PX"),
    _other("size", "size", None, _size,
           "render area in pixels: sets width and height (default: 1024 on the grid's longer side, square cells)",
           "WxH", attrs=("width", "height"), many="WxH sizes", bounds=(1, MAX_SIZE)),
    _other("range", "roughness", (0.0, 1.0), _range("roughness"),
           "perceptual roughness across the columns, inclusive (one value off an axis)", "LO:HI", many="LO:HI pairs",
           bounds=(0.0, 1.0), annotation=tuple[float, float]),
    _other("range", "metallic", (0.0, 1.0), _range("metallic"),
           "metallic down the rows, inclusive (one value off an axis)", "LO:HI",
           many="LO:HI pairs", bounds=(0.0, 1.0), annotation=tuple[float, float]),
    _other("color", "base_color", DEFAULT_BASE_COLOR, _color("base_color"), "linear base colour", "R,G,B",
           many="R,G,B colours (separated by ';')", bounds=(0.0, 1.0), annotation=tuple[float, float, float]),
    _other("names", "materials", (), _materials,
           f"a measured preset per row, overriding base_color (sets rows unless given): {', '.join(MATERIAL_PRESETS)}",
           "NAME,...", aliases=("row_materials",), attrs=("row_materials",), choices=tuple(MATERIAL_PRESETS),
           many="material lists (names joined by '+')", annotation=tuple[str, ...]),
    _other("env", "env", "studio", _env, f"{', '.join(ENV_PRESETS)}, or an .exr/.hdr/.npy equirect map", "NAME|FILE",
           sweep=ENV_PRESETS, annotation=str),
    _float("env_intensity", 1.0, 0.0, 1e6, "environment radiance scale"),
    _other("lights", "lights", DEFAULT_LIGHTS, _lights,
           f"default or none (a spec file can list [[lights]] with {', '.join(LIGHT_SETTINGS)})", "default|none",
           annotation=tuple),
    _bool("shadows", True, "soft shadows from the lights"),
    _bool("ao", True, "ambient occlusion"),
    _bool("ground", True, "the ground plane"),
    _bool("ibl", True, "image-based lighting from the environment"),
    _choice("tonemap", "aces", TONEMAPPERS, "tone mapper", labels={t.name: t.label for t in TONE_MAPPERS},
            sweep=TONEMAPPERS, display=True),
    _float("exposure", 0.0, -40.0, 40.0, "exposure in EV", metavar="EV", sweep=(-2.0, -1.0, 0.0, 1.0, 2.0),
           display=True),
    _float("reinhard_white", 4.0, 1e-3, 1e6, "white point of reinhard-extended", display=True),
    _int("spp", 1, 1, 1024, "samples per pixel"),
    _bool("antialias", True, "at spp 1 on the cells stage, the spheres' edges covered analytically "
          "(the pixel box the reference integrates)"),
    _choice("hdr_precision", "float32", HDR_PRECISIONS,
            "float format of the radiance target (float32 where spp > 1: the samples add up in it)"),
    _bool("multiscatter", True, "multiple-scattering energy compensation", sweep=(True, False)),
    _choice("brdf", "gltf", BRDF_MODELS, "BRDF model", sweep=BRDF_MODELS),
    _choice("stage", "cells", STAGES, "shared: one floor under the whole grid, neighbours in reflections; "
            "cells: each sphere on its own floor seen by its own camera (identical cells)", sweep=STAGES),
    _bool("cell_borders", True, "on the cells stage, an opaque image frames each cell in the chart's page colour "
          "(each cell is its own view of the stage: its near floor would meet the next cell's far floor in a seam)",
          display=True),
    _choice("camera", "perspective", CAMERAS, "projection", sweep=CAMERAS),
    _float("camera_azimuth", 0.0, -3600.0, 3600.0, "camera orbit angle around the grid, degrees", metavar="DEG",
           aliases=("azimuth",), sweep=(0.0, 30.0, 60.0, 90.0)),
    _float("camera_elevation", 8.0, -89.0, 89.0, "camera elevation, degrees", metavar="DEG", aliases=("elevation",)),
    _float("camera_distance_scale", 1.0, 1e-3, 1e3, "multiplies the framing distance (1: the grid fills the view)"),
    _choice("intersect", "auto", INTERSECT_METHODS, "ray-sphere intersection"),
    _float("sphere_radius", 1.0, 1e-4, 1e4, "sphere radius, scene units"),
    _float("spacing", 2.5, 1e-4, 1e6, "distance between sphere centres, scene units"),
    _bool("transparent", False, "transparent background; the floor becomes a shadow catcher (only its "
          "shadows and contact occlusion stay, in alpha)"),
    _other("color", "backdrop", (), _backdrop, "a page colour (sRGB, 0..1, as the page shows it) behind the "
           "spheres and their caught shadows: the transparent render laid onto it, labels and all, in "
           "text that reads on it (default: none)", "R,G,B",
           annotation=tuple),
    _other("text", "title", "", lambda v: text(v, "title", MAX_TITLE), "chart title (default: rows x cols)", "TEXT",
           annotation=str),
    _choice("quality", "default", tuple(QUALITY_PRESETS),
            "quality preset (seed002: a Shadertoy-style raymarcher's approach, the baseline)",
            sweep=tuple(QUALITY_PRESETS)),
    _choice("backend", "auto", BACKENDS, "GL backend (auto: EGL, then OSMesa)"),
    _int("device_index", 0, 0, 64, "EGL device by enumeration order"),
    _other("color", "ground_color", (0.18, 0.18, 0.18), _color("ground_color"), "linear ground colour", "R,G,B",
           many="R,G,B colours (separated by ';')", bounds=(0.0, 1.0), annotation=tuple[float, float, float]),
    _float("ground_roughness", 0.8, 0.0, 1.0, "ground perceptual roughness"),
    _bool("labels", True, "axis labels, title and footer around the render"),
    _other("bugs", "bugs", (), _bugs, "catalogued PBR mistakes to switch on (`sdfpbr bugs` lists them)",
           "NAME,...", aliases=("bug",), choices=tuple(BUGS), many="bug lists (names joined by '+')",
           annotation=tuple[str, ...]),
    _choice("textures", "none", TEXTURE_MODES,
            "sphere textures (procedural: riveted panels; hammered: a hammered-metal normal map)"),
    _other("path", "base_color_texture", "", _png("base_color_texture"), "sRGB base colour map (PNG)", "PNG",
           annotation=str),
    _other("path", "orm_texture", "", _png("orm_texture"), "linear occlusion/roughness/metallic map (PNG)", "PNG",
           annotation=str),
    _other("path", "normal_texture", "", _png("normal_texture"), "linear tangent-space normal map, OpenGL +Y (PNG)",
           "PNG", annotation=str),
    _choice("x_axis", "roughness", AXIS_PARAMS, "the material parameter across the columns"),
    _choice("y_axis", "metallic", AXIS_PARAMS, "the material parameter down the rows"),
    _other("numbers", "x_values", (), _numbers("x_values"),
           "explicit values across the columns, instead of the x parameter's range (sets cols unless given)",
           "X,...", many="number lists (joined by '+')", annotation=tuple[float, ...]),
    _other("numbers", "y_values", (), _numbers("y_values"),
           "explicit values down the rows, instead of the y parameter's range (sets rows unless given)",
           "Y,...", many="number lists (joined by '+')", annotation=tuple[float, ...]),
    _other("colors", "base_colors", (), _colors, "linear base colours, one per row or one per cell "
           "(overriding base_color; sets rows unless given)", "R,G,B;...", many="colour lists",
           annotation=tuple),
    *(_other("range", p.name, (p.value, p.value) if not p.axis_only else p.sweep,
             _range(p.name, p.lo, p.hi), f"{p.help}: one value, or LO:HI on an axis", "X|LO:HI",
             many="numbers or LO:HI pairs", bounds=(p.lo, p.hi), annotation=tuple[float, float])
      for p in PARAMS if p.name not in ("roughness", "metallic")),
    *(_other("color", name, default, _color(name), help, "R,G,B", many="R,G,B colours (separated by ';')",
             bounds=(0.0, 1.0), annotation=tuple[float, float, float])
      for name, (default, _lobe, help) in COLOR_PARAMS.items()),
    _choice("alpha_mode", "auto", ALPHA_MODES, "glTF alphaMode of the spheres (auto: blend where alpha < 1); "
            "alpha shows the backdrop, floor or sky behind a sphere and lets that share of the light through "
            "(its shadow and its occlusion of the floor fade with it)"),
    _float("alpha_cutoff", 0.5, 0.0, 1.0, "alpha_mode mask: alpha below this is cut out"),
    _other("path", "gltf", "", _gltf, "chart a glTF 2.0 asset's materials, one labelled cell each (its files must lie "
           "inside its folder); sets rows and cols unless given", "FILE", annotation=str),
    _other("names", "gltf_materials", (), _gltf_names, "the glTF materials to chart, in this order (default: all)",
           "NAME,...", aliases=("material",), many="material lists (names joined by '+')",
           annotation=tuple[str, ...]),
)

# The KHR lobes' fields, lobe by lobe (spec/material.py): a new lobe's fields join the help's
# materials group without a change here.
LOBE_FIELDS = tuple(name for lobe in LOBE_NAMES
                    for name in (*(p.name for p in PARAMS if p.lobe == lobe),
                                 *(c for c, (_, of, _) in COLOR_PARAMS.items() if of == lobe)))

# The chart options by concern, in the order `--help` shows them: every field in one group.
HELP_GROUPS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("grid and axes", ("rows", "cols", "size", "width", "height", "roughness", "metallic", "x_axis", "y_axis",
                       "x_values", "y_values")),
    ("materials", ("base_color", "base_colors", "materials", "base_color_hue", *LOBE_FIELDS, "alpha", "alpha_mode",
                   "alpha_cutoff")),
    ("environment and lights", ("env", "env_intensity", "lights", "shadows", "ao", "ibl")),
    ("stage, floor and camera", ("stage", "ground", "ground_color", "ground_roughness", "cell_borders", "camera",
                                 "camera_azimuth", "camera_elevation", "camera_distance_scale", "sphere_radius",
                                 "spacing", "intersect")),
    ("picture and page", ("tonemap", "exposure", "reinhard_white", "title", "labels", "transparent", "backdrop")),
    ("quality and GL", ("quality", "spp", "antialias", "multiscatter", "brdf", "hdr_precision", "backend",
                        "device_index")),
    ("PBR bugs", ("bugs",)),
    ("textures and glTF", ("textures", "base_color_texture", "orm_texture", "normal_texture", "gltf",
                           "gltf_materials")),
)

def names_file(key: str, value) -> bool:
    """Whether spec key ``key`` holding ``value`` names a file: an env that is no preset, a
    texture, a glTF asset."""
    return isinstance(value, str) and bool(value) and (
        key == "env" and value not in ENV_PRESETS or key.endswith("_texture") or key == "gltf")


def resolve_relative_files(mapping: Mapping[str, Any], base_dir: Path) -> dict:
    """A relative file named in a spec file or entry is found beside it first (then, as given,
    from the working directory)."""
    out = dict(mapping)
    for key, value in mapping.items():
        if names_file(key, value) and not Path(value).is_absolute() and (base_dir / value).exists():
            out[key] = str(base_dir / value)
    return out


FIELD_NAMES = tuple(f.name for f in FIELDS)
STORED_FIELDS = tuple(f for f in FIELDS if len(f.stored) == 1)   # one ChartSpec attribute each
_BY_NAME = {n: f for f in FIELDS for n in (f.name, *f.aliases)}
_BY_ATTR = {f.attr: f for f in STORED_FIELDS}


def resolve_field(name: str, what: str = "spec field", also=()) -> Field:
    """The field a name or alias (with '-' or '_') means; SpecError with a suggestion if none
    (``also``: other names valid where this one was found, such as an entry's keys)."""
    key = name.replace("-", "_") if isinstance(name, str) else name
    field = _BY_NAME.get(key) if isinstance(key, str) else None
    if field is None:
        raise SpecError(f"unknown {what} {quote(name)}{did_you_mean(key, [*_BY_NAME, *also])}")
    return field


DISPLAY_ATTRS = tuple(f.attr for f in FIELDS if f.display)


def radiance_fields(spec) -> tuple:
    """What decides a spec's radiance: every field but the display ones, and of its bugs those
    of the chart program (a display bug changes the display pass alone). Hashable."""
    return tuple((f.name, tuple(b for b in spec.bugs if BUGS[b].program != "display") if f.name == "bugs"
                  else getattr(spec, f.name))
                 for f in dataclass_fields(spec) if f.name not in DISPLAY_ATTRS)


def same_radiance(a, b) -> bool:
    """Whether specs ``a`` and ``b`` differ in display fields (tone map, exposure, ...) and
    display bugs alone: their charts' radiance is the same, and one's display image is the
    other's radiance through its own display pass."""
    return radiance_fields(a) == radiance_fields(b)


def field_for_attr(attr: str) -> Field:
    return _BY_ATTR[attr]


def attr_values(mapping: Mapping[str, Any], what: str = "option") -> dict[str, Any]:
    """Names (or aliases) and values -> ChartSpec attributes and values, for ``replace``.
    ``size`` becomes width and height; materials without rows sets rows (one per material), and
    without metallic makes every row a metal (the presets are measured metals: gold at
    metallic 0 would be a cream plastic)."""
    given: dict[str, str] = {}
    out: dict[str, Any] = {}
    for key, value in mapping.items():
        field = resolve_field(key, what)
        for attr in field.stored:
            if attr in given:
                raise SpecError(f"{quote(key)} and {quote(given[attr])} both set {attr}; give one")
            given[attr] = key
        if field.kind == "size":
            out["width"], out["height"] = field.check(value)
        else:
            out[field.attr] = value
    if out.get("x_values") and "cols" not in out:
        out["cols"] = len(_numbers("x_values")(out["x_values"]))
    if out.get("y_values") and "rows" not in out:
        out["rows"] = len(_numbers("y_values")(out["y_values"]))
    if out.get("base_colors") and "rows" not in out:
        out["rows"] = len(_colors(out["base_colors"]))
    if out.get("gltf") and "rows" not in out and "cols" not in out:
        from .gltf import gltf_materials, grid_for
        names = _gltf_names(out.get("gltf_materials", ()))
        out["rows"], out["cols"] = grid_for(len(gltf_materials(_gltf(out["gltf"]), names).materials))
    if out.get("row_materials") and "rows" not in out:
        out["row_materials"] = _materials(out["row_materials"])
        out["rows"] = len(out["row_materials"])
    if out.get("row_materials") and "metallic" not in out:
        out["metallic"] = (1.0, 1.0)
    return out


def field_value(spec, name: str):
    """A spec's value for a field name or alias (size: (width, height))."""
    field = resolve_field(name)
    values = tuple(getattr(spec, a) for a in field.stored)
    return values if len(values) > 1 else values[0]


# ---- command-line text and sweeps ----------------------------------------------------------------

def field_value_from_text(name: str, value_text: str):
    """One value as a flag or a sweep writes it: '0:1', '64x64', '1,0,0', 'gold,copper' or 'gold+copper'."""
    field = resolve_field(name)
    if field.kind in ("names", "bugs"):
        return field.check(parse_names(value_text, ",+"))
    return field.from_text(value_text)   # numbers: ',' or '+' between them


def sweep_values_from_text(name: str, values_text: str) -> list:
    """`--values` of a sweep: separated by ',' (by ';' when a value is a vector, such as
    base_color "1,0,0;0,1,0"); the items of a list value joined with '+'."""
    field = resolve_field(name)
    sep = ";" if ";" in values_text or field.kind == "color" else ","
    items = [t.strip() for t in str(values_text).split(sep)]
    if not values_text.strip() or not all(items):
        raise SpecError(f"--values must list values separated by '{sep}', got {quote(values_text)}")
    out = []
    for item in items:
        try:
            value = parse_names(item, "+") if field.kind in ("names", "bugs", "numbers") else field.parse(item)
        except SpecError:
            raise SpecError(f"{field.name} values must be {field.many}, got {quote(item)}") from None
        # lights stay a word: a sweep labels each panel with its value
        out.append(value if field.kind == "lights" else field.check(value))
    return out


def sweep_defaults(name: str) -> tuple:
    """The values a sweep over ``name`` uses when none are given."""
    field = resolve_field(name)
    if not field.sweep:
        with_defaults = ", ".join(f.name for f in FIELDS if f.sweep)
        raise SpecError(f"sweeping {field.name} needs values (--values); fields with defaults: {with_defaults}")
    return field.sweep


SWEEP_FIELDS = tuple(f.name for f in FIELDS if f.sweep)


# ---- writers: a spec as TOML and as flags ---------------------------------------------------------

def toml_value(v) -> str:
    """A TOML value for a spec value (bool, number, text, or a list of them)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)   # validated specs hold finite floats; repr reads back exactly
    if isinstance(v, str):
        # JSON's escapes are TOML's, except that TOML also wants DEL escaped.
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    raise TypeError(f"no TOML form for {v!r}")


def spec_to_toml(spec, comments=()) -> str:
    """A TOML spec, every field written out, that load_spec reads back to an equal spec."""
    lines = [f"# {c}" for c in comments]
    for field in STORED_FIELDS:
        if field.kind != "lights":
            lines.append(f"{field.name} = {toml_value(getattr(spec, field.attr))}")
    lights = spec.lights
    if not lights:
        lines.append("lights = []")
    for light in lights:   # after every top-level key: a [[table]] ends the top level
        lines += ["", "[[lights]]"] + [f"{k} = {toml_value(getattr(light, k))}" for k in LIGHT_SETTINGS]
    return "\n".join(lines) + "\n"


def spec_to_flags(spec, base=None) -> list[str]:
    """`sdfpbr chart` flags that turn ``base`` (default: the defaults) into ``spec``; only the
    fields that differ. Values go after '=' so a value starting with '-' stays a value."""
    flags = []
    for field in STORED_FIELDS:
        value = getattr(spec, field.attr)
        old = getattr(base, field.attr) if base is not None else field.check(field.default)
        if value == old:
            continue
        flag = field.option_strings[0]
        if field.kind == "bool":
            flags.append(flag if value else "--no-" + flag[2:])
        elif field.kind == "bugs":   # flags add bugs to the base's; they cannot take one away
            added = tuple(b for b in value if b not in old)
            if tuple(old) + added != tuple(value):
                raise SpecError(f"flags cannot turn bugs {list(old)} into {list(value)}; flags only add bugs")
            flags.append(f"{flag}={field.to_text(added)}")
        else:
            flags.append(f"{flag}={field.to_text(value)}")
    written = {f.split("=", 1)[0] for f in flags}
    if field_for_attr("row_materials").option_strings[0] in written:
        # Materials without rows or metallic read back as one metal row each (attr_values):
        # write both, so the flags read back to this spec's.
        for attr in ("rows", "metallic"):
            field = field_for_attr(attr)
            if field.option_strings[0] not in written:
                flags.append(f"{field.option_strings[0]}={field.to_text(getattr(spec, attr))}")
    if any(f.startswith(("--rows=", "--cols=")) for f in flags) and \
            not any(f.startswith(("--width=", "--height=")) for f in flags):
        # A size nobody chose follows the grid (chart_spec.grid_size): write it, so the flags
        # read back to this spec's size whatever it was.
        flags.append(f"--size={spec.width}x{spec.height}")
    if any(f.startswith(("--x-axis=", "--y-axis=")) for f in flags):
        # Parameters left at their defaults follow new axes (material.displaced_defaults):
        # write them all, so the flags read back to this spec whatever they were.
        written = {f.split("=", 1)[0] for f in flags}
        for p in PARAMS:
            field = resolve_field(p.name)
            if field.option_strings[0] not in written:
                flags.append(f"{field.option_strings[0]}={field.to_text(getattr(spec, field.attr))}")
    return flags


# ---- docs-entry files: a spec plus what the docs build does with it -----------------------------

ENTRY_SECTIONS = ("compare", "sweep")          # an entry has at most one of these tables
ENTRY_KEYS = ("caption", "spec") + ENTRY_SECTIONS


def split_entry(data: Mapping[str, Any], where: str = "entry") -> tuple[dict, dict]:
    """(spec mapping, entry mapping) of a docs-entry document. A chart entry keeps its spec keys
    at the top level; a [compare] or [sweep] entry keeps its base spec in a [spec] table."""
    entry = {k: data[k] for k in ENTRY_KEYS if k in data}
    sections = [k for k in ENTRY_SECTIONS if k in data]
    if len(sections) > 1:
        raise SpecError(f"{where}: an entry has either [compare] or [sweep], not both")
    if not sections:
        if "spec" in data:
            raise SpecError(f"{where}: [spec] belongs to [compare] or [sweep] entries; "
                            f"a chart entry puts its spec keys at the top level")
        spec = {k: v for k, v in data.items() if k not in ENTRY_KEYS}
        for key in spec:   # a misspelt entry key is suggested too
            try:
                resolve_field(key, "key", also=ENTRY_KEYS)
            except SpecError as exc:
                raise SpecError(f"{where}: {exc}") from None
        return spec, entry
    section = sections[0]
    extra = [k for k in data if k not in ENTRY_KEYS]
    if extra:
        raise SpecError(f"{where}: unknown top-level key {quote(extra[0])} in a [{section}] entry"
                        f"{did_you_mean(extra[0], ENTRY_KEYS)}; its spec keys go in [spec]; "
                        f"allowed: caption, spec, {section}")
    spec = data.get("spec", {})
    if not isinstance(spec, Mapping):
        raise SpecError(f"{where}: spec must be a table ([spec]), got {quote(spec)}")
    return dict(spec), entry


def read_entry_document(path: str | Path) -> tuple[dict, dict]:
    """(spec mapping, entry mapping) of a docs-entry or spec file, through the one TOML reader."""
    return split_entry(read_toml(path), where=str(path))
