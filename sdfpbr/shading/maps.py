"""The surface maps a chart can compose in: for each, its GL sampler, the shader option that
composes it in (textures.glsl) and what a material without that texture reads (so a stacked
map of many materials needs no per-layer switch). One table for the plan, the bake and the
upload; spec.gltf.GltfMaterials.has_textures names the same maps."""
from __future__ import annotations

from dataclasses import dataclass

WHITE = (255, 255, 255, 255)
FLAT = (128, 128, 255, 255)   # a tangent-space normal of (0, 0, 1)


@dataclass(frozen=True)
class SurfaceMap:
    name: str
    uniform: str
    option: str
    srgb: bool            # colour, decoded by an sRGB texture format; else linear data
    neutral: tuple        # RGBA8 of a material without the texture


MAPS = (
    SurfaceMap("base", "u_base_color_map", "HAS_BASE_COLOR_MAP", True, WHITE),       # RGB colour, A alpha
    SurfaceMap("orm", "u_orm_map", "HAS_ORM_MAP", False, WHITE),                     # occlusion, roughness, metallic
    SurfaceMap("normal", "u_normal_map", "HAS_NORMAL_MAP", False, FLAT),
    SurfaceMap("emissive", "u_emissive_map", "HAS_EMISSIVE_MAP", True, WHITE),
    # KHR extensions: clearcoat (R), clearcoat roughness (G), specular (B), sheen roughness (A)
    SurfaceMap("khr", "u_khr_map", "HAS_KHR_MAP", False, WHITE),
    SurfaceMap("coat_normal", "u_coat_normal_map", "HAS_COAT_NORMAL_MAP", False, FLAT),
    SurfaceMap("sheen_color", "u_sheen_color_map", "HAS_SHEEN_COLOR_MAP", True, WHITE),
    SurfaceMap("specular_color", "u_specular_color_map", "HAS_SPECULAR_COLOR_MAP", True, WHITE),
)
MAP_NAMES = tuple(m.name for m in MAPS)
MAP_OPTIONS = tuple(m.option for m in MAPS)
