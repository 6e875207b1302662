"""A glTF 2.0 asset's materials as chart cells (the ``gltf`` extra: pygltflib).

Each material becomes the keywords of one sdfpbr.spec.material.Material: the metallic-roughness factors, emissive factor and the
KHR_materials_clearcoat, _sheen, _specular, _ior and _emissive_strength factors. Textures are
not charted yet: a material that has any is named in ``ignored`` so the caller can say so.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ..errors import SpecError, did_you_mean
from .checks import quote

GLTF_SUFFIXES = (".gltf", ".glb")
_TEXTURE_KEYS = ("baseColorTexture", "metallicRoughnessTexture")
_MATERIAL_TEXTURE_KEYS = ("normalTexture", "occlusionTexture", "emissiveTexture")


@dataclass(frozen=True)
class GltfMaterials:
    materials: tuple[dict, ...]   # Material keywords, one per material
    ignored: tuple[str, ...]      # "material: what was not charted"


def _load(path: str):
    try:
        import pygltflib
    except ImportError:
        raise SpecError("reading glTF needs pygltflib: pip install 'sdfpbr[gltf]'") from None
    try:
        return pygltflib.GLTF2().load(path)
    except Exception as exc:   # pygltflib raises what json and struct raise on a bad file
        raise SpecError(f"gltf {path} cannot be read as glTF 2.0: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None


def _factor(value, default, n=None):
    if value is None:
        return default
    if n is not None:
        return tuple(float(v) for v in list(value)[:n])
    return float(value)


def _material(index: int, m) -> tuple[dict, list[str]]:
    name = m.name or f"material {index}"
    pbr = m.pbrMetallicRoughness
    ext = m.extensions or {}
    ignored = [k for k in _TEXTURE_KEYS if pbr is not None and getattr(pbr, k, None) is not None]
    ignored += [k for k in _MATERIAL_TEXTURE_KEYS if getattr(m, k, None) is not None]
    values = dict(name=name)
    if pbr is not None:
        values["base_color"] = _factor(pbr.baseColorFactor, (1.0, 1.0, 1.0), 3)
        values["metallic"] = _factor(pbr.metallicFactor, 1.0)
        values["roughness"] = _factor(pbr.roughnessFactor, 1.0)
    else:   # the glTF defaults: white, metallic 1, roughness 1
        values.update(base_color=(1.0, 1.0, 1.0), metallic=1.0, roughness=1.0)
    values["emissive"] = _factor(m.emissiveFactor, (0.0, 0.0, 0.0), 3)
    if "KHR_materials_emissive_strength" in ext:
        values["emissive_strength"] = _factor(ext["KHR_materials_emissive_strength"].get("emissiveStrength"), 1.0)
    if "KHR_materials_clearcoat" in ext:
        e = ext["KHR_materials_clearcoat"]
        values["clearcoat"] = _factor(e.get("clearcoatFactor"), 0.0)
        values["clearcoat_roughness"] = _factor(e.get("clearcoatRoughnessFactor"), 0.0)
        ignored += [k for k in ("clearcoatTexture", "clearcoatRoughnessTexture", "clearcoatNormalTexture") if k in e]
    if "KHR_materials_sheen" in ext:
        e = ext["KHR_materials_sheen"]
        values["sheen_color"] = _factor(e.get("sheenColorFactor"), (0.0, 0.0, 0.0), 3)
        values["sheen_roughness"] = _factor(e.get("sheenRoughnessFactor"), 0.0)
        ignored += [k for k in ("sheenColorTexture", "sheenRoughnessTexture") if k in e]
    if "KHR_materials_specular" in ext:
        e = ext["KHR_materials_specular"]
        values["specular"] = _factor(e.get("specularFactor"), 1.0)
        values["specular_color"] = _factor(e.get("specularColorFactor"), (1.0, 1.0, 1.0), 3)
        ignored += [k for k in ("specularTexture", "specularColorTexture") if k in e]
    if "KHR_materials_ior" in ext:
        ior = _factor(ext["KHR_materials_ior"].get("ior"), 1.5)
        values["ior"] = 1e9 if ior == 0.0 else ior   # glTF: 0 means infinite (f0 = 1)
    if m.alphaMode not in (None, "OPAQUE"):
        ignored.append(f"alphaMode {m.alphaMode}")
    _check(name, values)
    return values, [f"{name}: {k}" for k in ignored]


def _check(name: str, values: dict) -> None:
    for key, value in values.items():
        if key == "name":
            continue
        for v in value if isinstance(value, tuple) else (value,):
            if not math.isfinite(v) or v < 0.0 or (key not in ("emissive_strength", "ior") and v > 1.0):
                raise SpecError(f"material {quote(name)}: {key} {quote(value)} is outside glTF's range")


_memo: dict = {}


def gltf_materials(path: str, names: tuple[str, ...] = ()) -> GltfMaterials:
    """The materials of the asset at ``path`` (those named in ``names``, in that order; all
    without names), read once per file version."""
    p = Path(path)
    try:
        stat = p.stat()
    except OSError:
        raise SpecError(f"gltf file {path} does not exist") from None
    key = (str(p.resolve()), stat.st_mtime_ns, stat.st_size, tuple(names))
    if key not in _memo:
        doc = _load(str(p))
        read = [_material(i, m) for i, m in enumerate(doc.materials or [])]
        if not read:
            raise SpecError(f"gltf {path} has no materials")
        by_name = {m["name"]: (m, ig) for m, ig in read}
        if names:
            missing = [n for n in names if n not in by_name]
            if missing:
                raise SpecError(f"gltf {path} has no material {quote(missing[0])}{did_you_mean(missing[0], by_name)}; "
                                f"it has: {', '.join(by_name)}")
            read = [by_name[n] for n in names]
        _memo.clear()
        _memo[key] = GltfMaterials(tuple(m for m, _ in read), tuple(i for _, ig in read for i in ig))
    return _memo[key]


def grid_for(count: int) -> tuple[int, int]:
    """(rows, cols) with rows x cols = count, as square as whole rows allow (cols >= rows)."""
    rows = max(r for r in range(1, int(math.isqrt(count)) + 1) if count % r == 0)
    return rows, count // rows
