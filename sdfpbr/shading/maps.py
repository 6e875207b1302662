"""The surface maps a chart can compose in: for each, its GL sampler, the shader option that
composes it in (textures.glsl) and what a material without that texture reads (so a stacked
map of many materials needs no per-layer switch). One table for the plan, the bake and the
upload; spec.gltf.GltfMaterials.has_textures names the same maps. The lobes' maps come from
their rows in spec.material LOBES."""
from __future__ import annotations

from dataclasses import dataclass

from ..spec.material import LOBE_TEXTURES

WHITE = (255, 255, 255, 255)
FLAT = (128, 128, 255, 255)   # a tangent-space normal of (0, 0, 1)


@dataclass(frozen=True)
class SurfaceMap:
    name: str
    uniform: str
    option: str
    srgb: bool            # colour, decoded by an sRGB texture format; else linear data
    neutral: tuple        # RGBA8 of a material without the texture


# glTF 2.0's own maps.
CORE_MAPS = (
    SurfaceMap("base", "u_base_color_map", "HAS_BASE_COLOR_MAP", True, WHITE),       # RGB colour, A alpha
    SurfaceMap("orm", "u_orm_map", "HAS_ORM_MAP", False, WHITE),                     # occlusion, roughness, metallic
    SurfaceMap("normal", "u_normal_map", "HAS_NORMAL_MAP", False, FLAT),
    SurfaceMap("emissive", "u_emissive_map", "HAS_EMISSIVE_MAP", True, WHITE),
)


def _lobe_map(name: str, kind: str) -> SurfaceMap:
    """The map a lobe's textures go to (spec.material LOBES): shared data channels (the KHR
    map: clearcoat R, its roughness G, specular B, sheen roughness A), a colour or a normal."""
    return SurfaceMap(name, f"u_{name}_map", f"HAS_{name.upper()}_MAP", kind == "colour",
                      FLAT if kind == "normal" else WHITE)


MAPS = CORE_MAPS + tuple(_lobe_map(name, kind) for name, kind in
                         dict.fromkeys((t.map, t.kind) for t in LOBE_TEXTURES))
MAPS_BY_NAME = {m.name: m for m in MAPS}
MAP_NAMES = tuple(m.name for m in MAPS)
MAP_OPTIONS = tuple(m.option for m in MAPS)
