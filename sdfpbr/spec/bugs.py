"""The catalog of classic PBR mistakes, each one compile option away from the correct chart.

A bug named in ``ChartSpec.bugs`` changes exactly one option of one program (the chart program
or the display program): a ``BUG_*`` define, or an existing option set to the buggy value
(``TONEMAP = clamp``, ``MULTISCATTER`` off). ``Bug.correct(spec)`` adds what the bug needs to
be visible (e.g. textured spheres for the texture bugs); ``Bug.apply(spec)`` is that spec with
the bug switched on."""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from ..errors import SpecError, did_you_mean
from .material import GLTF_OWNS, MIN_PERCEPTUAL_ROUGHNESS
from .checks import quote
from .presets import Light


@dataclass(frozen=True)
class Bug:
    name: str
    summary: str                  # one line for `sdfpbr bugs`
    caption: str                  # what goes wrong, why, the fix
    program: str                  # "chart" or "display": the program whose source changes
    option: str                   # the compile option the bug sets ...
    value: Any = True             # ... and its buggy value
    requires: dict = field(default_factory=dict)   # spec overrides that make the bug visible
    axis_titles: dict = field(default_factory=dict)  # parameter -> the axis title a chart with the bug gets

    # dataclasses.replace re-runs the spec's own validation, so the catalog needs no import of
    # the spec module (which imports this one for bug names).
    def correct(self, spec):
        """``spec`` with what this bug needs to be visible (e.g. textured spheres); on a glTF
        asset's chart, what its materials decide (GLTF_OWNS) is left to them."""
        requires = {k: v for k, v in self.requires.items() if not (spec.gltf and k in GLTF_OWNS)}
        return replace(spec, **requires) if requires else spec

    def apply(self, spec):
        """``spec`` made visible for this bug, with the bug switched on."""
        base = self.correct(spec)
        return base if self.name in base.bugs else replace(base, bugs=tuple(base.bugs) + (self.name,))


def _bug(name, summary, caption, option, value=True, program="chart", axis_titles=None, **requires) -> Bug:
    return Bug(name, summary, caption, program, option, value, requires, axis_titles or {})


# A bug's figure (its mean FLIP) is measured at this size wherever it is quoted: `compare --bug`
# renders its panels at it, the contact sheet measures there and shows smaller panels, and the
# gallery's bug entries render at it.
BUG_MEASURE_SIZE = 512

_R_MIN = MIN_PERCEPTUAL_ROUGHNESS
_TEXTURED = {"textures": "procedural"}
# The lobe bugs show on a dielectric chart with their lobe down the rows (roughness across).
# Two soft boxes behind the spheres, left and right: light arriving at grazing half vectors.
_RIM_LIGHTS = tuple(Light("directional", direction=(x, 0.3, -0.74), intensity=6.0, angular_radius_deg=6.0)
                    for x in (0.6, -0.6))
_COATED = {"y_axis": "clearcoat", "clearcoat": (0.0, 1.0), "clearcoat_roughness": 0.1, "metallic": (0.0, 0.0),
           "base_color": (0.6, 0.05, 0.05)}
_SHEENED = {"y_axis": "sheen_roughness", "sheen_roughness": (0.2, 1.0), "sheen_color": (1.0, 0.5, 0.7),
            "metallic": (0.0, 0.0), "base_color": (0.1, 0.1, 0.3)}
_GEM = {"y_axis": "ior", "ior": (1.5, 2.5), "metallic": (0.0, 0.0), "base_color": (0.05, 0.05, 0.05)}

BUGS: dict[str, Bug] = {b.name: b for b in (
    _bug("unsquared-roughness", "perceptual roughness used as GGX alpha",
         "Low and mid roughness already look rough: highlights spread and dim, because alpha = r "
         "is larger than r * r below 1, so the chart no longer reads linearly. Only r = 1 agrees: "
         f"at r = 0 both clamp r to {_R_MIN:g}, which the bug uses as alpha {_R_MIN:g} instead of "
         f"{_R_MIN ** 2:.3f}. Fix: alpha = r * r.",
         "BUG_UNSQUARED_ROUGHNESS", axis_titles={"roughness": "roughness r (α = r, the bug)"}),
    _bug("metal-diffuse", "metals keep a Lambert body (no 1 - metallic)",
         "Metals look milky and plastic-like: a conductor has no diffuse body, but the Lambert "
         "term was added outside the metallic mix. Fix: weight diffuse by (1 - metallic).",
         "BUG_METAL_DIFFUSE"),
    _bug("diffuse-no-fresnel", "diffuse not weighted by 1 - F",
         "Dielectric rims glow too bright: light reflected by the coat cannot also enter the "
         "body, so Lambert must be weighted by (1 - F); two rim lights behind the spheres, at the "
         "grazing angles where F is large, show the rims taking the body's colour. Fix: "
         "mix(diffuse, specular, F).",
         "BUG_DIFFUSE_NO_FRESNEL", env="black", lights=_RIM_LIGHTS),
    _bug("clamp-tonemap", "clamp instead of a tone map",
         "Highlights and bright metals clip to flat white and shift hue: HDR radiance above 1 "
         "is cut off per channel. Fix: a tone mapper (ACES, Reinhard, Neutral) before encoding.",
         "TONEMAP", "clamp", program="display"),
    _bug("no-srgb-encode", "linear values written to an sRGB image",
         "The whole chart looks too dark and contrasty: the display expects sRGB-encoded "
         "values but got linear ones. Fix: apply the sRGB OETF last.",
         "BUG_NO_SRGB_ENCODE", program="display"),
    _bug("double-gamma", "sRGB encode applied twice",
         "Everything is washed out and grey: the image was encoded twice (e.g. an sRGB "
         "framebuffer plus a manual encode). Fix: encode exactly once.",
         "BUG_DOUBLE_GAMMA", program="display"),
    _bug("gamma-2.2", "pow(x, 1/2.2) instead of the sRGB curve",
         "Shadows are lifted and near-black banding differs: pow(1/2.2) is not the piecewise "
         "sRGB OETF (linear toe below 0.0031308), and the two curves differ most in the darks, so the "
         "chart is shown at -3 EV. Fix: the exact sRGB curve.",
         "BUG_GAMMA_POW", program="display", exposure=-3.0),
    _bug("double-tonemap", "Reinhard followed by ACES",
         "Flat, low-contrast image with dull highlights: the radiance was compressed by "
         "Reinhard and then again by ACES (as some Shadertoy-style shaders do). Fix: one tone mapper.",
         "BUG_DOUBLE_TONEMAP", program="display"),
    _bug("ibl-direct-k", "IBL LUT built with the direct-light Schlick k",
         "Environment reflections of metals come out too dark, by up to 15% towards the rims: "
         "the DFG LUT used G with k = (r+1)^2/8, meant for punctual lights, while shading uses "
         "height-correlated Smith. Fix: build the LUT with the shading's G.",
         "BUG_IBL_DIRECT_K"),
    _bug("single-scatter", "no multiple-scattering compensation",
         "Rough metals lose up to a third of their energy and look dark: single-scatter GGX "
         "drops light that bounces between microfacets. Fix: scale specular by 1 + F0 (1/E - 1).",
         "MULTISCATTER", False),
    _bug("fresnel-ndotv", "Fresnel of N.V for punctual lights",
         "Rims light up for every light and highlights lose their angular Fresnel: for a light "
         "the microfacet Fresnel depends on V.H, not N.V. Fix: F(V.H) for direct light.",
         "BUG_FRESNEL_NDOTV"),
    _bug("cosine-twice", "N.L applied twice",
         "The terminator is too soft and dark, lit sides fall off too fast: the cosine of "
         "Lambert's law was multiplied in by both the BRDF and the integrand. Fix: once.",
         "BUG_COSINE_TWICE"),
    _bug("no-cosine", "N.L missing",
         "Spheres look flat, lit almost to the terminator: the projected-area cosine of the "
         "rendering equation was left out. Fix: radiance = f * E * N.L.",
         "BUG_NO_COSINE"),
    _bug("unclamped-ndotv", "N.V not clamped at the silhouette",
         "Black specks on the rims: where a normal map tilts the shading normal away from the "
         "camera, N.V reaches zero or below and the textbook D G F / (4 N.L N.V) divides by it, "
         "turning the highlight negative (0/0 at N.V = 0). Shown on hammered metal lit by two rim "
         "lights behind the spheres, whose highlights fall on the grazing dimples it breaks. Fix: "
         "N.V = max(N.V, 1e-4), or the visibility form that never divides.",
         "BUG_UNCLAMPED_NDOTV", textures="hammered", lights=_RIM_LIGHTS),
    _bug("fewtap-ibl", "a few-tap blur instead of the split sum",
         "Rough reflections are blotchy and too sharp, diffuse ignores the hemisphere: five taps "
         "around R cannot integrate a GGX lobe. Fix: prefiltered radiance + DFG LUT + irradiance.",
         "BUG_FEWTAP_IBL"),
    _bug("ao-on-direct", "ambient occlusion applied to direct light",
         "Contact regions stay dark even where the sun hits them: AO approximates blocked "
         "environment light, not a punctual light (that is what shadows do); shown under a dim "
         "uniform sky, so the sun carries most of the light. Fix: AO on IBL only.",
         "BUG_AO_ON_DIRECT", env="uniform", env_intensity=0.3),
    _bug("normal-map-srgb", "normal map sampled as sRGB",
         "Bumps lean and flatten in one direction: the normal texture was decoded as colour, "
         "bending the vectors towards -1. Fix: sample normal maps as linear data.",
         "BUG_NORMAL_MAP_SRGB", **_TEXTURED),
    _bug("normal-map-green-flip", "DirectX normal map read as OpenGL",
         "Bumps look dented, lit from the wrong side vertically: the green channel convention "
         "(Y down in DirectX, up in OpenGL/glTF) is flipped. Fix: invert green on import.",
         "BUG_NORMAL_MAP_GREEN_FLIP", **_TEXTURED),
    _bug("orm-srgb", "roughness/metallic texture sampled as sRGB",
         "Textured spheres turn glossier and less metallic than their factors: the ORM data "
         "was decoded as colour, darkening mid values (0.5 -> 0.21). Fix: sample ORM as linear.",
         "BUG_ORM_SRGB", **_TEXTURED),
    _bug("clearcoat-adds", "clearcoat added on top of the base, not layered",
         "Coated spheres glow at their rims and gain energy: light the coat reflects cannot also "
         "reach the base, so the base must lose the coat's share, clearcoat * F(N.V). Fix: "
         "mix(base, coat, clearcoat * F) (KHR_materials_clearcoat's fresnel_coat).",
         "BUG_CLEARCOAT_ADDS", **_COATED),
    _bug("sheen-no-scaling", "sheen added without the albedo scaling",
         "Velvet looks washed out and gains energy: the sheen's reflection is added to the whole "
         "base instead of taking its share, 1 - max(sheen colour) E_s, from it. Fix: scale the "
         "base by the sheen's albedo scaling (KHR_materials_sheen).",
         "BUG_SHEEN_NO_SCALING", **_SHEENED),
    _bug("ior-ignored", "dielectric f0 fixed at 0.04 whatever the ior",
         "Gems and glass look like plastic: KHR_materials_ior's f0 = ((ior - 1)/(ior + 1))^2 "
         "(0.17 at ior 2.4) and KHR_materials_specular's colour and weight were dropped for the "
         "core 0.04. Fix: read f0 from ior and the specular colour.",
         "BUG_IOR_IGNORED", **_GEM),
)}

# Every define a bug can add, for the composer's option table.
BUG_DEFINES = tuple(b.option for b in BUGS.values() if b.option.startswith("BUG_"))


def get_bug(name: str) -> Bug:
    if isinstance(name, str) and name in BUGS:
        return BUGS[name]
    raise SpecError(f"unknown bug {quote(name)}{did_you_mean(name, BUGS)}; allowed: {', '.join(BUGS)}")

