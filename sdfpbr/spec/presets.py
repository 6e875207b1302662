"""The named things a spec can pick: material and quality presets, environments, tone mappers,
and the light record. Data only; the field table (fields.py) says which spec field takes which.

Each list of names is written here once. The field table, the CLI help, the shader option
schema (shading/plan.py), the float64 oracles, the stress cases, the gallery and the tests read
it from here (docs/extending.md: what to add where)."""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, Mapping

from ..errors import SpecError, did_you_mean
from .checks import choice, number, quote, unit, vec3

# Measured reflectance at normal incidence (linear sRGB primaries), as in Filament's material
# guide and physicallybased.info; metals use these as base colour with metallic = 1.
MATERIAL_PRESETS: dict[str, tuple[float, float, float]] = {
    "gold": (1.000, 0.766, 0.336),
    "copper": (0.955, 0.638, 0.538),
    "silver": (0.972, 0.960, 0.915),
    "iron": (0.560, 0.570, 0.580),
    "aluminium": (0.913, 0.922, 0.924),
}


def glsl_word(name: str) -> str:
    """A spec value as the GLSL option value it selects: 'aces-hill' -> 'aces_hill'."""
    return name.replace("-", "_")


# The procedural environments (env.glsl has a branch for each; a spec's env may also be a file).
ENV_PRESETS = ("studio", "sky", "uniform", "black")


@dataclass(frozen=True)
class ToneMapper:
    """One tone mapper. ``name`` is the spec value; ``glsl`` the word its branch in
    shaders/tonemap.glsl tests (``#elif TONEMAP == <glsl>``) and the suffix of its functions,
    ``tonemap_<glsl>`` there (a one-line curve sits in its branch) and in float64 in
    sdfpbr/oracle/display.py; ``label`` says what it is, for the help and the docs."""
    name: str
    label: str

    @property
    def glsl(self) -> str:
        return glsl_word(self.name)


TONE_MAPPERS = (
    ToneMapper("none", "no curve; the encode clips at 1"),
    ToneMapper("clamp", "clipped to 0..1"),
    ToneMapper("reinhard", "Reinhard's curve"),
    ToneMapper("reinhard-extended", "Reinhard's curve with reinhard_white mapped to 1"),
    ToneMapper("aces", "Narkowicz's fit of the ACES filmic curve"),
    ToneMapper("aces-hill", "Hill's fit of the ACES RRT and ODT"),
    ToneMapper("neutral", "Khronos PBR Neutral"),
    ToneMapper("agx", "Blender's AgX base look, by Troy Sobotka"),
)
TONEMAPPERS = tuple(t.name for t in TONE_MAPPERS)
BRDF_MODELS = ("gltf", "schlick-ggx")
CAMERAS = ("perspective", "orthographic")
# The stage: "cells" gives every sphere the same studio (its own floor, seen by its own camera),
# so cells with the same material look the same; "shared" is one scene, a grid of spheres over
# one floor, where neighbours and the floor appear in reflections.
STAGES = ("shared", "cells")
# How a ray meets a sphere: the closed form or marching the SDF. A spec may also say "auto":
# the closed form, unless the quality preset forces marching.
INTERSECTIONS = ("analytic", "march")
INTERSECT_METHODS = ("auto", *INTERSECTIONS)
BACKENDS = ("auto", "egl", "osmesa")
# The maps each procedural texture mode bakes (gpu.textures): riveted panels carry colour, ORM
# and normals; hammered metal only normals, so the chart's own materials stand.
PROCEDURAL_MAPS = {"procedural": ("base", "orm", "normal"), "hammered": ("normal",)}
TEXTURE_MODES = ("none", *PROCEDURAL_MAPS)
LIGHT_KINDS = ("directional", "point")
NORMAL_METHODS = ("tetrahedron", "central")
HDR_PRECISIONS = ("float32", "float16")   # the float format of the radiance target
MAX_GRID = 64
MAX_LIGHTS = 16
ORBITS = ("light", "camera")                    # what turns in an animation
DEFAULT_FPS = 15.0
# WebP animation frames: lossy at this quality and method unless lossless is asked. The default
# chart's 24-frame light orbit: 1.32 MB, mean error 0.81 of 255, 170 ms a frame (quality 92 at
# method 0: 1.98 MB, 0.75 of 255, 90 ms).
WEBP_QUALITY = 88
WEBP_METHOD = 4
MAX_SIZE = 16384 * 4
# A title's characters: a few wrapped lines over the chart. A 500 000-character one was set as
# a 163 x 950196 image.
MAX_TITLE = 400
MAX_CAPTION = 4000   # a sheet's or a gallery image's caption (the bug catalog's longest: ~500)


@dataclass(frozen=True)
class Light:
    """A punctual light. Directional: ``direction`` points towards the light, ``intensity`` is
    illuminance at normal incidence, ``angular_radius_deg`` sets the shadow penumbra and the
    highlight size. Point: ``position``, ``intensity`` in candela-like units (E = I / d^2),
    ``radius`` the emitting sphere's (world units; 0 is a point), which sets the highlight's
    size and the shadow's penumbra as the angle it subtends does for a directional light."""
    kind: str = "directional"
    direction: tuple[float, float, float] = (0.0, 1.0, 0.0)
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0
    angular_radius_deg: float = 0.0
    range: float = 100.0
    radius: float = 0.0

    def __post_init__(self):
        s = object.__setattr__
        s(self, "kind", choice(self.kind, "light kind", LIGHT_KINDS))
        if self.kind == "directional":
            s(self, "direction", unit(self.direction, "light direction"))
        else:   # unused by point lights, but validated alike so specs compare and round-trip
            s(self, "direction", vec3(self.direction, "light direction"))
        # Bounds keep radiance finite in float32 (1e300 became inf on the GPU); intensity
        # carries the magnitude, color the tint.
        s(self, "position", vec3(self.position, "light position", -1e12, 1e12))
        s(self, "color", vec3(self.color, "light color", 0.0, 1e6))
        s(self, "intensity", number(self.intensity, "light intensity", 0.0, 1e12))
        s(self, "angular_radius_deg", number(self.angular_radius_deg, "light angular_radius_deg", 0.0, 45.0))
        s(self, "range", number(self.range, "light range", 1e-6, 1e12))
        s(self, "radius", number(self.radius, "light radius", 0.0, 1e12))


# A studio's two soft boxes, far enough to be directional and large enough that the smoothest
# sphere shows each as a small disc (a 6-degree box reflects ~7 px wide on a 128-px sphere).
# The key stands 57 degrees up and 33 degrees left of the cells stage's camera: high and frontal
# enough that its penumbra stays inside the cell, 1.8 degrees or more from its border for cells
# from 1:4 to 3:1 (41 degrees up and 47 left, it ran into the next cell and was cut at the
# seam). The dim, low fill's long soft shadow still reaches the cell's left edge; it is ~5% of
# the floor's direct light, under the step of up to ~9% the environment makes at a seam.
KEY_LIGHT = Light("directional", direction=(-0.2966, 0.8387, 0.4568), color=(1.0, 0.95, 0.88),
                  intensity=3.0, angular_radius_deg=6.0)
FILL_LIGHT = Light("directional", direction=(0.78, 0.30, 0.55), color=(0.85, 0.92, 1.0),
                   intensity=0.4, angular_radius_deg=10.0)
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
    # Image-based specular: "split_sum" reads the prefiltered map once (the lookup leaned toward
    # the normal for rough lobes when ibl_dominant_dir); "sampled" integrates the environment
    # per pixel with ibl_pixel_samples GGX (VNDF) samples and mip-filtered lookups.
    ibl_method: str = "split_sum"
    ibl_dominant_dir: str = "moments"   # split_sum lookup: "none" (along R), "frostbite", "moments"
    ibl_two_lobe: bool = True          # split_sum lookup: a narrower core plus a tail read along N
    ibl_two_tap: bool = True           # ... fitted over roughness and N.V, the core read twice along
                                       # the lobe's stretch (with ibl_dominant_dir "moments")
    ibl_pixel_samples: int = 0
    bounce_rays: int = 5             # cells stage: rays averaging the sphere's light onto its floor
    bounce_mirror_directions: int = 16   # ... and directions of the stage a smooth sphere mirrors onto it
    bounce_texels: int = 8           # ... shaded on a grid of this many texels per sphere radius (0: every pixel)
    bounce_specular_samples: int = 4   # ... and samples of the floor's glossy lobe, its reflection of the sphere
    hidden_sky_samples: int = 256    # cells stage: reads of the sky a sphere hides from its foot (ao.glsl)
    # The ground's IBL from a table over the view direction, baked once per environment with
    # this many filtered samples per texel (0: the split sum per pixel); ground_ibl_size texels
    # on an edge.
    ground_ibl_samples: int = 1024
    floor_prepass: bool = True         # cells stage: the floor's static light shaded once per cell pixel
    # cells stage: the light between a sphere and its floor, one round trip more per draw of
    # the bounce cache (bounce_cache.glsl; 0: the sphere gets none of its own light back), on
    # a tile of bounce_cache_texels a side per cell, read by each sphere point from
    # bounce_gather_samples directions a lobe
    bounce_iterations: int = 2
    bounce_cache_texels: int = 16
    bounce_gather_samples: int = 8
    # cells stage: the floor seen from each sphere point rather than the centre, a table over
    # the normal of floor_parallax_size texels a cube face, floor_parallax_samples directions each
    floor_parallax: bool = True
    floor_parallax_size: int = 16
    floor_parallax_samples: int = 512
    sphere_prepass: bool = True        # cells stage: cells sharing all but metallic shade their sphere once per slot
    # the sheen's environment light read along its lobe's mean direction (shading.sheen)
    sheen_lean: bool = True
    neighbour_light: bool = True     # shared stage: the nearest spheres' light in each sphere's (2x the draw)
    # ... averaging n x n points of each pixel's box where the sphere is small: n = round(this /
    # its radius in px), 1 to 4 (0: one point). 40: 3 on the 256² chart's 16-px spheres, where
    # the key light's 6° highlight is under a pixel wide; 1 from 27 px.
    sphere_samples_radius: int = 40
    # ... and this many points of the covered part of each silhouette pixel, spread evenly
    # across the silhouette, where the sphere's shading changes fastest (edge_coverage.glsl;
    # 1: the part's median point)
    edge_samples: int = 1
    ground_ibl_size: int = 128       # ~64 texels from horizon to zenith, as the DFG LUT's NdotV
    scene_sdf: str = "nearest_cell"   # all_spheres: the union loops over every sphere (seed002)
    hit_epsilon: float = 0.0         # absolute hit threshold added to hit_scale * pixel footprint
    intersect: str = ""              # forces "march" or "analytic"; "" follows the spec
    brdf: str = ""                   # forces a BRDF model; "" follows the spec
    implied_bugs: tuple[str, ...] = ()   # shortcuts a preset takes on purpose (seed002)


QUALITY_PRESETS: dict[str, Quality] = {
    "draft": Quality(march_steps=64, shadow_steps=24, ao_taps=3, env_bake_size=128, ibl_size=64,
                     ibl_samples=32, dfg_size=32, dfg_samples=512, sh_size=16, sphere_samples_radius=0,
                     ibl_dominant_dir="none", ibl_two_lobe=False, bounce_rays=1, bounce_mirror_directions=8,
                     hidden_sky_samples=32, bounce_iterations=1, bounce_gather_samples=4, bounce_specular_samples=2,
                     ground_ibl_size=64, neighbour_light=False),
    "default": Quality(),
    "high": Quality(march_steps=160, hit_scale=0.25, shadow_steps=96, ao_taps=6, env_bake_size=512,
                    ibl_size=256, ibl_samples=256, dfg_size=128, dfg_samples=2048,
                    # the sky behind the sphere in 1024 shares at its foot (fewer as its disc
                    # shrinks, ao.glsl): at 256 everywhere 128² against its 327680-spp reference
                    # went 0.0180 -> 0.0173 FLIP (64 -> 256)
                    ibl_method="sampled", ibl_pixel_samples=256, hidden_sky_samples=1024,
                    # silhouette pixels' covered part in 4 points: 128² 0.0154 -> 0.0143 FLIP, the
                    # 1024² frame's draws 1.27 -> 1.57 s here
                    edge_samples=4,
                    # the studio a polished sphere mirrors onto its floor from 64 directions: 128²
                    # 0.0143 -> 0.0138 (the floor in front of the polished metals 0.92 -> 0.69 %
                    # dark; 256: 0.66 %); the 1024² frame 790 / 776 ms with 16 / 64 here
                    bounce_mirror_directions=64, bounce_iterations=4, bounce_gather_samples=32,
                    bounce_cache_texels=32, bounce_specular_samples=16),
    # A Shadertoy-style raymarcher's approach on our scene (docs/model.md): every sphere in the SDF, 100 steps to a
    # fixed 1e-3 threshold, central-difference normals, five-tap environment blur, Schlick-GGX with the
    # direct-light k everywhere, Reinhard then ACES, SDF-tap AO, 32 shadow steps.
    "seed002": Quality(march_steps=100, hit_scale=0.0, hit_epsilon=1e-3, normal_method="central",
                       shadow_steps=32, ao_method="sdf", ao_taps=5, scene_sdf="all_spheres",
                       intersect="march", brdf="schlick-ggx", ground_ibl_samples=0, floor_prepass=False,
                       implied_bugs=("fewtap-ibl", "ibl-direct-k", "double-tonemap")),
}

# The presets that trade time for error, cheapest first (seed002 copies another renderer's
# approach instead).
QUALITY_LEVELS = ("draft", "default", "high")

LIGHT_SETTINGS = tuple(f.name for f in fields(Light))


def light_from_mapping(m: Mapping[str, Any]) -> Light:
    """A [[lights]] table; '-' and '_' are the same in its keys, as everywhere in a spec."""
    if isinstance(m, Light):
        return m
    if not isinstance(m, Mapping):
        raise SpecError(f"each light must be a table of settings, got {quote(m)}")
    values = {}
    for k, v in m.items():
        name = str(k).replace("-", "_")
        if name not in LIGHT_SETTINGS:
            raise SpecError(f"unknown light setting {quote(k)}{did_you_mean(name, LIGHT_SETTINGS)}; "
                            f"allowed: {', '.join(LIGHT_SETTINGS)}")
        values[name] = v
    return Light(**values)
