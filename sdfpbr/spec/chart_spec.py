"""Chart specifications: frozen dataclasses, defaults users expect, validation in one place.

A spec comes from Python keywords, a TOML file or CLI flags; all three go through
``make_spec``, so every path gets the same checks and the same one-line messages.
"""
from __future__ import annotations

import difflib
import math
import sys
import tomllib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Mapping

from ..errors import SpecError

# Measured reflectance at normal incidence (linear sRGB primaries), as in Filament's material
# guide and physicallybased.info; metals use these as base colour with metallic = 1.
MATERIAL_PRESETS: dict[str, tuple[float, float, float]] = {
    "gold": (1.000, 0.766, 0.336),
    "copper": (0.955, 0.638, 0.538),
    "silver": (0.972, 0.960, 0.915),
    "iron": (0.560, 0.570, 0.580),
    "aluminium": (0.913, 0.922, 0.924),
}
ENV_PRESETS = ("studio", "sky", "uniform", "black")
TONEMAPPERS = ("none", "clamp", "reinhard", "reinhard-extended", "aces", "aces-hill", "neutral")
BRDF_MODELS = ("gltf", "schlick-ggx")
CAMERAS = ("perspective", "orthographic")
INTERSECT_METHODS = ("auto", "analytic", "march")
BACKENDS = ("auto", "egl", "osmesa")
TEXTURE_MODES = ("none", "procedural")
LIGHT_KINDS = ("directional", "point")
NORMAL_METHODS = ("tetrahedron", "central")
HDR_PRECISIONS = ("float32", "float16")   # the float format of the radiance target
MAX_GRID = 64
MAX_SIZE = 16384 * 4


def _closest(word: str, choices) -> str:
    match = difflib.get_close_matches(word, list(choices), n=1)
    return f" (did you mean {match[0]!r}?)" if match else ""


def _unit(v, what: str) -> tuple[float, float, float]:
    v = _vec3(v, what)
    n = math.hypot(*v)   # no overflow to inf (which made (1e200, 0, 0) a zero vector)
    if not n > 0:
        raise SpecError(f"{what} must be a non-zero vector, got {v}")
    if abs(n - 1.0) <= 4 * sys.float_info.epsilon:
        return v         # already unit: keep it, so a spec written out and read back is equal
    return tuple(c / n for c in v)


def _vec3(v, what: str) -> tuple[float, float, float]:
    try:
        out = tuple(float(c) for c in v)
    except (TypeError, ValueError):
        raise SpecError(f"{what} must be three numbers, got {v!r}") from None
    if len(out) != 3 or not all(math.isfinite(c) for c in out):
        raise SpecError(f"{what} must be three finite numbers, got {v!r}")
    return out


def _number(v, what: str, lo: float = -math.inf, hi: float = math.inf, integer: bool = False):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise SpecError(f"{what} must be a number, got {v!r}")
    if integer and math.isfinite(v) and int(v) != v:   # int(inf) and int(nan) raise
        raise SpecError(f"{what} must be a whole number, got {v!r}")
    if not (math.isfinite(v) and lo <= v <= hi):
        raise SpecError(f"{what} must be in [{lo:g}, {hi:g}], got {v!r}")
    return int(v) if integer else float(v)


def _choice(v, what: str, choices) -> str:
    if v not in choices:
        raise SpecError(f"{what} {v!r} is not allowed{_closest(str(v), choices)}; allowed: {', '.join(choices)}")
    return v


@dataclass(frozen=True)
class Light:
    """A punctual light. Directional: ``direction`` points towards the light, ``intensity`` is
    illuminance at normal incidence, ``angular_radius_deg`` sets the shadow penumbra and the
    highlight size. Point: ``position``, ``intensity`` in candela-like units (E = I / d^2)."""
    kind: str = "directional"
    direction: tuple[float, float, float] = (0.0, 1.0, 0.0)
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0
    angular_radius_deg: float = 0.0
    range: float = 100.0

    def __post_init__(self):
        s = object.__setattr__
        s(self, "kind", _choice(self.kind, "light kind", LIGHT_KINDS))
        if self.kind == "directional":
            s(self, "direction", _unit(self.direction, "light direction"))
        else:   # unused by point lights, but validated alike so specs compare and round-trip
            s(self, "direction", _vec3(self.direction, "light direction"))
        s(self, "position", _vec3(self.position, "light position"))
        s(self, "color", _vec3(self.color, "light color"))
        if min(self.color) < 0:
            raise SpecError(f"light color must be >= 0, got {self.color}")
        s(self, "intensity", _number(self.intensity, "light intensity", 0.0, 1e12))
        s(self, "angular_radius_deg", _number(self.angular_radius_deg, "light angular_radius_deg", 0.0, 45.0))
        s(self, "range", _number(self.range, "light range", 1e-6, 1e12))


KEY_LIGHT = Light("directional", direction=(-0.55, 0.65, 0.52), color=(1.0, 0.95, 0.88),
                  intensity=3.0, angular_radius_deg=2.5)
FILL_LIGHT = Light("point", position=(9.0, 1.5, 7.0), color=(0.85, 0.92, 1.0), intensity=25.0, range=60.0)
DEFAULT_LIGHTS = (KEY_LIGHT, FILL_LIGHT)


@dataclass(frozen=True)
class Quality:
    """Knobs that trade time for error; named presets live in QUALITY_PRESETS."""
    march_steps: int = 96
    hit_scale: float = 0.5
    normal_method: str = "tetrahedron"
    shadow_steps: int = 48
    ao_method: str = "analytic"     # exact sphere occlusion; "sdf" = taps along the normal
    ao_taps: int = 5
    env_bake_size: int = 256
    ibl_size: int = 128
    ibl_samples: int = 64
    dfg_size: int = 64
    dfg_samples: int = 2048
    sh_size: int = 32
    scene_sdf: str = "nearest_cell"   # all_spheres: the union loops over every sphere (seed 002)
    hit_epsilon: float = 0.0         # absolute hit threshold added to hit_scale * pixel footprint
    intersect: str = ""              # forces "march" or "analytic"; "" follows the spec
    brdf: str = ""                   # forces a BRDF model; "" follows the spec
    implied_bugs: tuple[str, ...] = ()   # shortcuts a preset takes on purpose (seed002)


QUALITY_PRESETS: dict[str, Quality] = {
    "draft": Quality(march_steps=64, shadow_steps=24, ao_taps=3, env_bake_size=128, ibl_size=64,
                     ibl_samples=32, dfg_size=32, dfg_samples=256, sh_size=16),
    "default": Quality(),
    "high": Quality(march_steps=160, hit_scale=0.25, shadow_steps=96, ao_taps=6, env_bake_size=512,
                    ibl_size=256, ibl_samples=256, dfg_size=128, dfg_samples=2048),
    # The approach of shared seed 002 on our scene: every sphere in the SDF, 100 steps to a fixed
    # 1e-3 threshold, central-difference normals, five-tap environment blur, Schlick-GGX with the
    # direct-light k everywhere, Reinhard then ACES, SDF-tap AO, 32 shadow steps.
    "seed002": Quality(march_steps=100, hit_scale=0.0, hit_epsilon=1e-3, normal_method="central",
                       shadow_steps=32, ao_method="sdf", ao_taps=5, scene_sdf="all_spheres",
                       intersect="march", brdf="schlick-ggx",
                       implied_bugs=("fewtap-ibl", "ibl-direct-k", "double-tonemap")),
}


@dataclass(frozen=True)
class ChartSpec:
    rows: int = 5
    cols: int = 5
    width: int = 1024
    height: int = 1024
    roughness: tuple[float, float] = (0.0, 1.0)       # perceptual roughness, inclusive range
    metallic: tuple[float, float] = (0.0, 1.0)
    base_color: tuple[float, float, float] = (0.75, 0.75, 0.75)   # linear
    row_materials: tuple[str, ...] = ()               # named presets per row, overrides base_color
    env: str = "studio"                               # preset name or an .exr / .npy path
    env_intensity: float = 1.0
    lights: tuple[Light, ...] = DEFAULT_LIGHTS
    shadows: bool = True
    ao: bool = True
    ground: bool = True
    ibl: bool = True
    tonemap: str = "aces"
    exposure: float = 0.0                             # EV
    reinhard_white: float = 4.0
    spp: int = 1
    hdr_precision: str = "float32"                    # float16: half-float radiance target, clamped to 65504
    multiscatter: bool = True
    brdf: str = "gltf"
    camera: str = "perspective"
    camera_azimuth: float = 0.0                       # degrees, orbit around the grid's vertical axis
    camera_elevation: float = 8.0                     # degrees; slightly down so the ground reads as a floor
    camera_distance_scale: float = 1.0                # multiplies the framing distance (1: the grid fills the view)
    intersect: str = "auto"
    sphere_radius: float = 1.0
    spacing: float = 2.5
    transparent: bool = False
    title: str = ""
    quality: str = "default"
    backend: str = "auto"
    device_index: int = 0
    ground_color: tuple[float, float, float] = (0.18, 0.18, 0.18)
    ground_roughness: float = 0.8
    labels: bool = True
    bugs: tuple[str, ...] = ()                        # names from sdfpbr.bugs.BUGS, switched on
    textures: str = "none"                            # none | procedural (normal, ORM, base colour maps)
    base_color_texture: str = ""                      # PNG, sRGB; replaces the procedural one
    orm_texture: str = ""                             # PNG, linear: R occlusion, G roughness, B metallic
    normal_texture: str = ""                          # PNG, linear tangent space, OpenGL (+Y up)

    def __post_init__(self):
        s = object.__setattr__
        s(self, "rows", _number(self.rows, "rows", 1, MAX_GRID, integer=True))
        s(self, "cols", _number(self.cols, "cols", 1, MAX_GRID, integer=True))
        s(self, "width", _number(self.width, "width", 1, MAX_SIZE, integer=True))
        s(self, "height", _number(self.height, "height", 1, MAX_SIZE, integer=True))
        for name in ("roughness", "metallic"):
            rng = getattr(self, name)
            if not isinstance(rng, (tuple, list)) or len(rng) != 2:
                raise SpecError(f"{name} must be a LO:HI pair, got {rng!r}")
            lo, hi = (_number(v, name, 0.0, 1.0) for v in rng)
            s(self, name, (lo, hi))
        s(self, "base_color", _vec3(self.base_color, "base_color"))
        if not all(0.0 <= c <= 1.0 for c in self.base_color):
            raise SpecError(f"base_color components must be in [0, 1] (linear), got {self.base_color}")
        mats = tuple(self.row_materials)
        for m in mats:
            _choice(m, "row material", tuple(MATERIAL_PRESETS))
        if mats and len(mats) != self.rows:
            raise SpecError(f"row_materials names {len(mats)} materials for {self.rows} rows; give one per row")
        s(self, "row_materials", mats)
        if not isinstance(self.env, str) or not self.env:
            raise SpecError(f"env must be a preset ({', '.join(ENV_PRESETS)}) or an .exr/.npy file")
        if self.env not in ENV_PRESETS:
            path = Path(self.env)
            if path.suffix.lower() not in (".exr", ".npy"):
                raise SpecError(f"env {self.env!r} is not a preset{_closest(self.env, ENV_PRESETS)}; "
                                f"allowed: {', '.join(ENV_PRESETS)} or an .exr/.npy file")
            if not path.is_file():
                raise SpecError(f"env file {self.env} does not exist")
        s(self, "env_intensity", _number(self.env_intensity, "env_intensity", 0.0, 1e6))
        lights = self.lights
        if isinstance(lights, str):
            lights = {"default": DEFAULT_LIGHTS, "none": ()}.get(lights)
            if lights is None:
                raise SpecError(f"lights {self.lights!r} is not allowed; allowed: default, none, or a list of lights")
        lights = tuple(l if isinstance(l, Light) else _light_from_mapping(l) for l in lights)
        if len(lights) > 16:
            raise SpecError(f"at most 16 lights, got {len(lights)}")
        s(self, "lights", lights)
        for flag in ("shadows", "ao", "ground", "ibl", "multiscatter", "transparent", "labels"):
            if not isinstance(getattr(self, flag), bool):
                raise SpecError(f"{flag} must be true or false, got {getattr(self, flag)!r}")
        s(self, "tonemap", _choice(self.tonemap, "tonemap", TONEMAPPERS))
        s(self, "exposure", _number(self.exposure, "exposure", -40.0, 40.0))
        s(self, "reinhard_white", _number(self.reinhard_white, "reinhard_white", 1e-3, 1e6))
        s(self, "spp", _number(self.spp, "spp", 1, 1024, integer=True))
        s(self, "brdf", _choice(self.brdf, "brdf", BRDF_MODELS))
        s(self, "camera", _choice(self.camera, "camera", CAMERAS))
        s(self, "camera_azimuth", _number(self.camera_azimuth, "camera_azimuth", -3600.0, 3600.0))
        s(self, "camera_elevation", _number(self.camera_elevation, "camera_elevation", -89.0, 89.0))
        s(self, "camera_distance_scale", _number(self.camera_distance_scale, "camera_distance_scale", 1e-3, 1e3))
        s(self, "hdr_precision", _choice(self.hdr_precision, "hdr_precision", HDR_PRECISIONS))
        s(self, "intersect", _choice(self.intersect, "intersect", INTERSECT_METHODS))
        s(self, "sphere_radius", _number(self.sphere_radius, "sphere_radius", 1e-4, 1e4))
        s(self, "spacing", _number(self.spacing, "spacing", 1e-4, 1e6))
        if not isinstance(self.title, str):
            raise SpecError(f"title must be text, got {self.title!r}")
        s(self, "quality", _choice(self.quality, "quality", tuple(QUALITY_PRESETS)))
        s(self, "backend", _choice(self.backend, "backend", BACKENDS))
        s(self, "device_index", _number(self.device_index, "device_index", 0, 64, integer=True))
        s(self, "ground_color", _vec3(self.ground_color, "ground_color"))
        if not all(0.0 <= c <= 1.0 for c in self.ground_color):   # negative made negative radiance
            raise SpecError(f"ground_color components must be in [0, 1] (linear), got {self.ground_color}")
        s(self, "ground_roughness", _number(self.ground_roughness, "ground_roughness", 0.0, 1.0))
        from .bugs import get_bug
        bugs = (self.bugs,) if isinstance(self.bugs, str) else self.bugs
        if not isinstance(bugs, (tuple, list)):
            raise SpecError(f"bugs must be a list of bug names, got {self.bugs!r}")
        s(self, "bugs", tuple(get_bug(b).name for b in bugs))
        s(self, "textures", _choice(self.textures, "textures", TEXTURE_MODES))
        for name in ("base_color_texture", "orm_texture", "normal_texture"):
            path = getattr(self, name)
            if not isinstance(path, str):
                raise SpecError(f"{name} must be a PNG path, got {path!r}")
            if path and (Path(path).suffix.lower() != ".png" or not Path(path).is_file()):
                raise SpecError(f"{name} {path!r} is not an existing .png file")

    # Derived values, one definition each.
    def row_base_colors(self) -> list[tuple[float, float, float]]:
        if self.row_materials:
            return [MATERIAL_PRESETS[m] for m in self.row_materials]
        return [self.base_color] * self.rows

    def column_roughness(self) -> list[float]:
        return _inclusive(self.roughness, self.cols)

    def row_metallic(self) -> list[float]:
        return _inclusive(self.metallic, self.rows)

    def quality_settings(self) -> Quality:
        return QUALITY_PRESETS[self.quality]

    def uses_analytic_intersection(self) -> bool:
        forced = self.quality_settings().intersect
        return forced == "analytic" if forced else self.intersect in ("auto", "analytic")

    def uses_textures(self) -> bool:
        return self.textures != "none" or any((self.base_color_texture, self.orm_texture, self.normal_texture))

    def brdf_model(self) -> str:
        return self.quality_settings().brdf or self.brdf

    def active_bugs(self) -> tuple[str, ...]:
        """The spec's bugs plus those its quality preset takes on purpose."""
        implied = self.quality_settings().implied_bugs
        return self.bugs + tuple(b for b in implied if b not in self.bugs)

    def to_dict(self) -> dict[str, Any]:
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "lights":
                v = [{k.name: getattr(l, k.name) for k in fields(l)} for l in v]
            elif isinstance(v, tuple):
                v = list(v)
            out[f.name] = v
        return out


def _inclusive(rng: tuple[float, float], n: int) -> list[float]:
    lo, hi = rng
    return [lo] if n == 1 else [lo + (hi - lo) * i / (n - 1) for i in range(n)]


def _light_from_mapping(m: Mapping[str, Any]) -> Light:
    if not isinstance(m, Mapping):
        raise SpecError(f"each light must be a table of settings, got {m!r}")
    names = {f.name for f in fields(Light)}
    for k in m:
        if k not in names:
            raise SpecError(f"unknown light setting {k!r}{_closest(k, names)}; allowed: {', '.join(sorted(names))}")
    return Light(**m)


SPEC_KEYS = tuple(f.name for f in fields(ChartSpec))


def make_spec(base: ChartSpec | None = None, **overrides) -> ChartSpec:
    """A validated spec: ``base`` (or the defaults) with ``overrides``; unknown keys are errors."""
    for key in overrides:
        if key not in SPEC_KEYS:
            raise SpecError(f"unknown option {key!r}{_closest(key, SPEC_KEYS)}")
    try:
        return replace(base or ChartSpec(), **overrides)
    except TypeError as exc:   # a wrongly typed value that the checks did not name
        raise SpecError(str(exc)) from None


def spec_from_mapping(data: Mapping[str, Any], base: ChartSpec | None = None, where: str = "spec") -> ChartSpec:
    values = {}
    for key, value in data.items():
        name = key.replace("-", "_")
        if name not in SPEC_KEYS and name != "size":   # size = "WxH" sets width and height
            raise SpecError(f"{where}: unknown key {key!r}{_closest(name, SPEC_KEYS)}")
        if name in ("roughness", "metallic") and isinstance(value, str):
            value = parse_range(value, name)
        if name == "size":
            continue
        values[name] = value
    if "size" in data:
        values["width"], values["height"] = parse_size(data["size"])
    try:
        return make_spec(base, **values)
    except SpecError as exc:
        raise SpecError(f"{where}: {exc}") from None


def load_spec(path: str | Path, base: ChartSpec | None = None) -> ChartSpec:
    from .toml_file import read_toml
    return spec_from_mapping(read_toml(path), base, where=str(path))


def parse_range(text: str, what: str) -> tuple[float, float]:
    parts = str(text).split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        return float(parts[0]), float(parts[1])
    except ValueError:
        raise SpecError(f"{what} must be LO:HI, e.g. 0:1, got {text!r}") from None


def parse_size(text) -> tuple[int, int]:
    if isinstance(text, (list, tuple)) and len(text) == 2:
        w, h = text
    else:
        parts = str(text).lower().split("x")
        if len(parts) != 2:
            raise SpecError(f"size must be WxH, e.g. 1024x1024, got {text!r}")
        w, h = parts
    try:
        w, h = int(w), int(h)
    except ValueError:
        raise SpecError(f"size must be WxH with whole numbers, got {text!r}") from None
    return w, h


def parse_color(text: str) -> tuple[float, float, float]:
    parts = str(text).split(",")
    try:
        if len(parts) != 3:
            raise ValueError
        return tuple(float(p) for p in parts)
    except ValueError:
        raise SpecError(f"base color must be R,G,B (linear, 0..1), got {text!r}") from None
