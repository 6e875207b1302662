"""A glTF 2.0 asset's materials as chart cells (the ``gltf`` extra: pygltflib).

Each material becomes the keywords of one sdfpbr.spec.material.Material: the metallic-roughness
factors, emissive factor and the KHR_materials_clearcoat, _sheen, _specular, _ior and
_emissive_strength factors, the alpha mode; and its base-colour, metallic-roughness, normal,
occlusion and emissive textures become TextureRefs (the image's bytes from the .glb's buffer,
a data URI or a file beside the .gltf, its sampler's wrap and filter modes,
KHR_texture_transform), which gpu.textures bakes onto the sphere, as do the KHR extensions'
textures. What is not charted (other material extensions: transmission, volume, ...) is
named in ``ignored`` so the caller can say so.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ..errors import SpecError, did_you_mean
from .checks import quote
from .presets import MAX_GRID

GLTF_SUFFIXES = (".gltf", ".glb")
TEXTURE_EXTENSIONS = ("KHR_texture_transform",)   # read on every texture reference
MATERIAL_EXTENSION_PREFIXES = ("KHR_materials_", "KHR_texture_", "EXT_texture_")   # what a chart's cells show
CHARTED_EXTENSIONS = ("KHR_materials_clearcoat", "KHR_materials_sheen", "KHR_materials_specular", "KHR_materials_ior",
                      "KHR_materials_emissive_strength")
# glTF sampler enums: wrap modes and filters. The four mipmap minification modes read as one:
# the texels under the layer texel's footprint averaged (gpu.textures), which mipmapping with
# anisotropic filtering approaches; an unset filter is the mipmapped one, as viewers default.
WRAP_MODES = {33071: "clamp", 33648: "mirror", 10497: "repeat"}
MAG_FILTERS = {9728: "nearest", 9729: "linear"}
MIN_FILTERS = {9728: "nearest", 9729: "linear", 9984: "mipmap", 9985: "mipmap", 9986: "mipmap", 9987: "mipmap"}


@dataclass(frozen=True)
class TextureRef:
    """One texture of a material, as the sphere samples it. The sphere's (u, v) stands for
    every texCoord set (it has only one); ``transform`` is KHR_texture_transform's (offset,
    rotation, scale); ``amount`` the normal texture's scale or the occlusion's strength;
    ``mag_filter`` and ``min_filter`` the sampler's (MAG_FILTERS', MIN_FILTERS' names)."""
    data: bytes
    what: str                               # "material 'x' baseColorTexture", for messages
    wrap: tuple[str, str] = ("repeat", "repeat")
    mag_filter: str = "linear"
    min_filter: str = "mipmap"
    transform: tuple = ((0.0, 0.0), 0.0, (1.0, 1.0))
    amount: float = 1.0


@dataclass(frozen=True)
class MaterialTextures:
    base_color: TextureRef | None = None
    metallic_roughness: TextureRef | None = None
    normal: TextureRef | None = None
    occlusion: TextureRef | None = None
    emissive: TextureRef | None = None
    # The KHR extensions' maps: clearcoat (R), its roughness (G) and normal; sheen colour (RGB)
    # and roughness (A); specular (A) and specular colour (RGB).
    clearcoat: TextureRef | None = None
    clearcoat_roughness: TextureRef | None = None
    clearcoat_normal: TextureRef | None = None
    sheen_color: TextureRef | None = None
    sheen_roughness: TextureRef | None = None
    specular: TextureRef | None = None
    specular_color: TextureRef | None = None


@dataclass(frozen=True)
class GltfMaterials:
    materials: tuple[dict, ...]   # Material keywords, one per material
    ignored: tuple[str, ...]      # "material: what was not charted"
    textures: tuple = ()          # MaterialTextures, one per material
    files: tuple = ()             # the files beside the asset that it names (images, buffers)

    @property
    def has_textures(self) -> dict[str, bool]:
        """Which maps (sdfpbr.shading.maps) the chart composes in: those any material has a
        texture for (the ORM map: metallic-roughness or occlusion; the KHR map: clearcoat, its
        roughness, sheen roughness or specular)."""
        t = self.textures
        def any_of(*names):
            return any(getattr(m, n) for m in t for n in names)
        return {"base": any_of("base_color"), "orm": any_of("metallic_roughness", "occlusion"),
                "normal": any_of("normal"), "emissive": any_of("emissive"),
                "khr": any_of("clearcoat", "clearcoat_roughness", "sheen_roughness", "specular"),
                "coat_normal": any_of("clearcoat_normal"), "sheen_color": any_of("sheen_color"),
                "specular_color": any_of("specular_color")}


def _load(path: str):
    try:
        import pygltflib
    except ImportError:
        raise SpecError("reading glTF needs pygltflib: pip install 'sdfpbr[gltf]'") from None
    try:
        doc = pygltflib.GLTF2().load(path)
    except Exception as exc:   # pygltflib raises what json and struct raise on a bad file
        raise SpecError(f"gltf {path} cannot be read as glTF 2.0: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None
    version = getattr(getattr(doc, "asset", None), "version", None)
    if not isinstance(version, str) or version.split(".")[0] != "2":
        raise SpecError(f"gltf {path} is glTF version {quote(version)}; sdfpbr reads glTF 2.x")
    # A loader must refuse an asset that requires an extension it does not implement (glTF 2.0,
    # 3.12). sdfpbr reads the materials and their images, not meshes: a required extension of
    # those (KHR_materials_*, KHR_texture_*, EXT_texture_*) it does not read would change what
    # it charts; a mesh's (Draco, quantization, meshopt) does not.
    required = doc.extensionsRequired if isinstance(doc.extensionsRequired, list) else []
    unknown = [e for e in required if isinstance(e, str) and e.startswith(MATERIAL_EXTENSION_PREFIXES)
               and e not in (*CHARTED_EXTENSIONS, *TEXTURE_EXTENSIONS)]
    if unknown:
        raise SpecError(f"gltf {path} requires {quote(unknown[0])}, which sdfpbr does not chart; of the "
                        f"materials' extensions it reads {', '.join((*CHARTED_EXTENSIONS, *TEXTURE_EXTENSIONS))}")
    return doc


def _factor(value, default, what: str, length: int | None = None):
    """A number (length None) or a list of ``length`` numbers from the asset, as floats;
    ``default`` where it is absent. Anything else is the asset's fault, said in one line."""
    if value is None:
        return default
    def number(v):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise SpecError(f"{what}: {quote(value)} is not {'a number' if length is None else f'{length} numbers'}")
        return float(v)
    if length is None:
        return number(value)
    if not isinstance(value, (list, tuple)) or len(value) != length:
        raise SpecError(f"{what}: {quote(value)} is not {length} numbers")
    return tuple(number(v) for v in value)


def _material_name(index: int, m) -> str:
    return m.name if isinstance(m.name, str) and m.name else f"material {index}"


def _ignored(index: int, m) -> list[str]:
    """What of material m the chart leaves out: the extensions it does not chart."""
    ext = m.extensions if isinstance(m.extensions, dict) else {}
    return [f"{_material_name(index, m)}: {k}" for k in ext if k not in CHARTED_EXTENSIONS]


def _material(index: int, m) -> dict:
    name = _material_name(index, m)
    pbr = m.pbrMetallicRoughness
    ext = m.extensions if isinstance(m.extensions, dict) else {}
    values = dict(name=name)

    def factor(value, default, key, length=None):
        return _factor(value, default, f"material {quote(name)} {key}", length)

    def extension(key):
        e = ext.get(key, {})
        if not isinstance(e, dict):
            raise SpecError(f"material {quote(name)}: {key} is not a JSON object")
        return e

    # The glTF defaults where a factor is absent: white, alpha 1, metallic 1, roughness 1.
    rgba = factor(pbr and pbr.baseColorFactor, (1.0, 1.0, 1.0, 1.0), "baseColorFactor", 4)
    values.update(base_color=rgba[:3], alpha=rgba[3],
                  metallic=factor(pbr and pbr.metallicFactor, 1.0, "metallicFactor"),
                  roughness=factor(pbr and pbr.roughnessFactor, 1.0, "roughnessFactor"))
    values["emissive"] = factor(m.emissiveFactor, (0.0, 0.0, 0.0), "emissiveFactor", 3)
    if "KHR_materials_emissive_strength" in ext:
        values["emissive_strength"] = factor(extension("KHR_materials_emissive_strength").get("emissiveStrength"), 1.0,
                                             "emissiveStrength")
    if "KHR_materials_clearcoat" in ext:
        e = extension("KHR_materials_clearcoat")
        values["clearcoat"] = factor(e.get("clearcoatFactor"), 0.0, "clearcoatFactor")
        values["clearcoat_roughness"] = factor(e.get("clearcoatRoughnessFactor"), 0.0, "clearcoatRoughnessFactor")
    if "KHR_materials_sheen" in ext:
        e = extension("KHR_materials_sheen")
        values["sheen_color"] = factor(e.get("sheenColorFactor"), (0.0, 0.0, 0.0), "sheenColorFactor", 3)
        values["sheen_roughness"] = factor(e.get("sheenRoughnessFactor"), 0.0, "sheenRoughnessFactor")
    if "KHR_materials_specular" in ext:
        e = extension("KHR_materials_specular")
        values["specular"] = factor(e.get("specularFactor"), 1.0, "specularFactor")
        values["specular_color"] = factor(e.get("specularColorFactor"), (1.0, 1.0, 1.0), "specularColorFactor", 3)
    if "KHR_materials_ior" in ext:
        ior = factor(extension("KHR_materials_ior").get("ior"), 1.5, "ior")
        values["ior"] = 1e9 if ior == 0.0 else ior   # glTF: 0 means infinite (f0 = 1)
    mode = m.alphaMode if m.alphaMode is not None else "OPAQUE"
    if mode not in ("OPAQUE", "MASK", "BLEND"):
        raise SpecError(f"material {quote(name)}: alphaMode {quote(mode)} is not OPAQUE, MASK or BLEND")
    values["alpha_cutoff"] = factor(m.alphaCutoff, 0.5, "alphaCutoff")
    _check(name, values)
    values["alpha_mode"] = mode.lower()
    return values


def _check(name: str, values: dict) -> None:
    for key, value in values.items():
        if key == "name":
            continue
        for v in value if isinstance(value, tuple) else (value,):
            if not math.isfinite(v) or v < 0.0 or (key not in ("emissive_strength", "ior", "alpha_cutoff") and v > 1.0):
                raise SpecError(f"material {quote(name)}: {key} {quote(value)} is outside glTF's range")


def _bytes_of_uri(uri: str, base: Path, what: str) -> bytes:
    import base64
    from urllib.parse import unquote
    if uri.startswith("data:"):
        try:
            return base64.b64decode(uri.split(",", 1)[1])
        except (IndexError, ValueError):
            raise SpecError(f"{what}: its data URI cannot be decoded") from None
    try:
        return (base / unquote(uri)).read_bytes()
    except OSError:
        raise SpecError(f"{what}: {uri} beside the asset cannot be read") from None


def _entry(items, index, what: str, kind: str):
    """items[index] for an index the asset gives: a whole number naming an existing entry
    (Python's negative indices are not glTF's)."""
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(items or ()):
        raise SpecError(f"{what}: {kind} {quote(index)} does not exist")
    return items[index]


def _image_bytes(doc, base: Path, index, what: str) -> bytes:
    image = _entry(doc.images, index, what, "image")
    if image.uri is not None:
        return _bytes_of_uri(image.uri, base, what)
    view = _entry(doc.bufferViews, image.bufferView, what, "buffer view")
    buffer = _entry(doc.buffers, view.buffer, what, "buffer")
    blob = _bytes_of_uri(buffer.uri, base, what) if buffer.uri is not None else doc.binary_blob()
    start, length = view.byteOffset or 0, view.byteLength
    if not all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in (start, length)):
        raise SpecError(f"{what}: its buffer view's byteOffset and byteLength must be whole numbers >= 0")
    if blob is None or start + length > len(blob):
        raise SpecError(f"{what}: its buffer view reaches past the buffer")
    return bytes(blob[start:start + length])


def _texture_ref(doc, base: Path, info, what: str, amount_key: str | None = None) -> TextureRef | None:
    """A textureInfo (pygltflib's, or an extension's JSON object) as a TextureRef."""
    if info is None:
        return None
    if isinstance(info, dict):   # inside an extension pygltflib leaves it JSON
        from types import SimpleNamespace
        info = SimpleNamespace(index=info.get("index"), extensions=info.get("extensions"),
                               **({amount_key: info.get(amount_key)} if amount_key else {}))
    elif not hasattr(info, "index"):
        raise SpecError(f"{what} is not a JSON object")
    texture = _entry(doc.textures, info.index, what, "texture")
    if texture.source is None:
        raise SpecError(f"{what}: its texture has no image")
    sampler = None if texture.sampler is None else _entry(doc.samplers, texture.sampler, what, "sampler")
    wrap = []
    for key in ("wrapS", "wrapT"):
        mode = getattr(sampler, key, None) if sampler else None
        if mode is not None and mode not in WRAP_MODES:
            raise SpecError(f"{what}: its sampler's {key} {quote(mode)} is not a glTF wrap mode "
                            f"({', '.join(f'{k} {v}' for k, v in WRAP_MODES.items())})")
        wrap.append(WRAP_MODES.get(mode, "repeat"))
    filters = []
    for key, modes, unset in (("magFilter", MAG_FILTERS, "linear"), ("minFilter", MIN_FILTERS, "mipmap")):
        mode = getattr(sampler, key, None) if sampler else None
        if mode is not None and mode not in modes:
            raise SpecError(f"{what}: its sampler's {key} {quote(mode)} is not a glTF {key} "
                            f"({', '.join(str(k) for k in modes)})")
        filters.append(modes.get(mode, unset))
    extensions = info.extensions if info.extensions is not None else {}
    t = extensions.get("KHR_texture_transform", {}) if isinstance(extensions, dict) else None
    if not isinstance(t, dict):
        raise SpecError(f"{what}: its extensions or KHR_texture_transform is not a JSON object")
    transform = (_factor(t.get("offset"), (0.0, 0.0), f"{what} offset", 2),
                 _factor(t.get("rotation"), 0.0, f"{what} rotation"),
                 _factor(t.get("scale"), (1.0, 1.0), f"{what} scale", 2))
    amount = _factor(getattr(info, amount_key, None), 1.0, f"{what} {amount_key}") if amount_key else 1.0
    if not all(math.isfinite(v) for v in (*transform[0], transform[1], *transform[2], amount)):
        raise SpecError(f"{what}: KHR_texture_transform or its {amount_key or 'factor'} holds a non-finite number")
    return TextureRef(_image_bytes(doc, base, texture.source, what), what, tuple(wrap), *filters, transform, amount)


def _textures(doc, base: Path, index: int, m) -> MaterialTextures:
    name = quote(_material_name(index, m))
    pbr = m.pbrMetallicRoughness
    ext = m.extensions if isinstance(m.extensions, dict) else {}
    def ref(info, key, amount_key=None):
        return _texture_ref(doc, base, info, f"material {name} {key}", amount_key)
    def ext_ref(extension, key, amount_key=None):
        e = ext.get(extension)
        return ref(e.get(key), key, amount_key) if isinstance(e, dict) else None
    return MaterialTextures(
        ref(pbr and pbr.baseColorTexture, "baseColorTexture"),
        ref(pbr and pbr.metallicRoughnessTexture, "metallicRoughnessTexture"),
        ref(m.normalTexture, "normalTexture", "scale"),
        ref(m.occlusionTexture, "occlusionTexture", "strength"),
        ref(m.emissiveTexture, "emissiveTexture"),
        ext_ref("KHR_materials_clearcoat", "clearcoatTexture"),
        ext_ref("KHR_materials_clearcoat", "clearcoatRoughnessTexture"),
        ext_ref("KHR_materials_clearcoat", "clearcoatNormalTexture", "scale"),
        ext_ref("KHR_materials_sheen", "sheenColorTexture"),
        ext_ref("KHR_materials_sheen", "sheenRoughnessTexture"),
        ext_ref("KHR_materials_specular", "specularTexture"),
        ext_ref("KHR_materials_specular", "specularColorTexture"))


# The last asset read: (path, its stat, names) -> (GltfMaterials, the stats of the files beside
# it that it names), so that an image edited beside a .gltf is read again too.
_memo: dict = {}


def _beside(doc, base: Path) -> tuple:
    """(path, mtime, size) of every file the asset names beside it (images, buffers)."""
    from urllib.parse import unquote
    uris = [i.uri for i in doc.images or []] + [b.uri for b in doc.buffers or []]
    return tuple((str(base / unquote(u)), *_stat(base / unquote(u)))
                 for u in uris if isinstance(u, str) and not u.startswith("data:"))


def _stat(path: Path) -> tuple:
    try:
        st = path.stat()
    except OSError:
        return (None, None)
    return (st.st_mtime_ns, st.st_size)


def gltf_materials(path: str, names: tuple[str, ...] = ()) -> GltfMaterials:
    """The materials of the asset at ``path`` (those named in ``names``, in that order; all
    without names), read once per version of the asset and of the files beside it."""
    p = Path(path)
    try:
        stat = p.stat()
    except OSError:
        raise SpecError(f"gltf file {path} does not exist") from None
    key = (str(p.resolve()), stat.st_mtime_ns, stat.st_size, tuple(names))
    hit = _memo.get(key)
    if hit is None or any(_stat(Path(f)) != (mtime, size) for f, mtime, size in hit[1]):
        doc = _load(str(p))
        beside = _beside(doc, p.parent)     # before the images are read
        read = [(_material(i, m), _ignored(i, m), _textures(doc, p.parent, i, m))
                for i, m in enumerate(doc.materials or [])]
        if not read:
            raise SpecError(f"gltf {path} has no materials")
        by_name = {m["name"]: (m, ig, tx) for m, ig, tx in read}
        if names:
            missing = [n for n in names if n not in by_name]
            if missing:
                raise SpecError(f"gltf {path} has no material {quote(missing[0])}{did_you_mean(missing[0], by_name)}; "
                                f"it has: {', '.join(by_name)}")
            read = [by_name[n] for n in names]
        _memo.clear()
        _memo[key] = (GltfMaterials(tuple(m for m, _, _ in read), tuple(i for _, ig, _ in read for i in ig),
                                    tuple(tx for _, _, tx in read), tuple(f for f, _, _ in beside)), beside)
    return _memo[key][0]


def grid_for(count: int) -> tuple[int, int]:
    """(rows, cols) with rows x cols = count, as square as whole rows allow (cols >= rows); a
    grid wider than MAX_GRID is refused here, naming the materials (not the cols it would be)."""
    rows = max(r for r in range(1, int(math.isqrt(count)) + 1) if count % r == 0)
    if count // rows > MAX_GRID:
        raise SpecError(f"the asset's {count} materials make a {rows} x {count // rows} grid, wider than "
                        f"{MAX_GRID} cells; chart some of them with --material NAME,...")
    return rows, count // rows
