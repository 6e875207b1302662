"""A glTF 2.0 asset's materials as chart cells.

Each material becomes the keywords of one sdfpbr.spec.material.Material: the metallic-roughness
factors, emissive factor and the KHR_materials_clearcoat, _sheen, _specular, _ior and
_emissive_strength factors, the alpha mode; and its base-colour, metallic-roughness, normal,
occlusion and emissive textures become TextureRefs (the image's bytes from the .glb's buffer,
a data URI or a file beside the .gltf, its sampler's wrap and filter modes,
KHR_texture_transform), which gpu.textures bakes onto the sphere, as do the KHR extensions'
textures. What is not charted (other material extensions: transmission, volume, ...) is
named in ``ignored`` so the caller can say so.

An asset is untrusted input, read as such:

* The asset, and every buffer and image file it names, is read through sdfpbr.inputs: a
  regular file within its kind's size limit (a FIFO or /dev/zero is refused, not waited on),
  its JSON nested at most inputs.MAX_NESTING deep. A GLB container is taken apart here (its
  header's version must be 2).
* A file's uri, percent-decoded, must lead to a file inside the asset's folder with symlinks
  resolved (inputs.confined): an absolute path, a ``file:`` URI or a ``..`` out is refused in
  words that do not tell whether the outside file exists, before anything outside is statted.
* Values are taken as the JSON gives them. sdfpbr reads the JSON itself rather than through
  pygltflib's dataclasses (the ``gltf`` extra, which the tests use to write assets): their
  decoder (dataclasses_json) converts each value to its field's type, so that
  ``"metallicFactor": "1"`` or ``true`` read as 1.0, ``"emissiveFactor": "000"`` as three
  zeros, an index 2.7 as 2 and ``"extensionsRequired": "KHR_x"`` as a list of letters; and
  it warns on stderr, naming its own file. Here a value of the wrong type is refused.
* Text from the asset (material and extension names, uris) is quoted, its control characters
  escaped, in every note and message.
"""
from __future__ import annotations

import math
import os
import re
import struct
from dataclasses import dataclass
from pathlib import Path

from ..errors import SpecError, did_you_mean
from ..inputs import check_input, confined, parse_json, read_input
from .checks import quote
from .material import LOBE_TEXTURES, LOBES, PARAMS
from .presets import MAX_GRID

GLTF_SUFFIXES = (".gltf", ".glb")
TEXTURE_EXTENSIONS = ("KHR_texture_transform",)   # read on every texture reference
CHARTED_EXTENSIONS = tuple(e.name for lobe in LOBES for e in lobe.gltf)   # the KHR lobes' (spec.material)
# Factors glTF does not bound by 1 (the lobes' parameters with a larger range, and the cutoff).
UNBOUNDED_FACTORS = frozenset({p.name for p in PARAMS if p.hi > 1.0} | {"alpha_cutoff"})
# Extensions of meshes alone: they compress or quantize vertex data, or instance a mesh on
# nodes. sdfpbr charts each material on its own sphere and reads no mesh, so an asset that
# requires one of these charts the same as without it.
MESH_EXTENSIONS = ("KHR_draco_mesh_compression", "KHR_mesh_quantization", "EXT_meshopt_compression",
                   "EXT_mesh_gpu_instancing")
# What an asset may require (glTF 2.0, 3.12: a loader refuses an asset requiring any other):
# what is charted, KHR_texture_transform, and the mesh extensions. Every other extension
# changes what a material looks like (unlit, transmission, a vendor's ACME_materials_*), where
# its images come from (KHR_texture_basisu, EXT_texture_webp), or what a scene does with it
# (lights, animation pointers, variants), none of which the chart shows.
HONOURED_EXTENSIONS = (*CHARTED_EXTENSIONS, *TEXTURE_EXTENSIONS, *MESH_EXTENSIONS)
# glTF sampler enums: wrap modes and filters. The four mipmap minification modes read as one:
# the texels under the layer texel's footprint averaged (gpu.textures), which mipmapping with
# anisotropic filtering approaches; an unset filter is the mipmapped one, as viewers default.
WRAP_MODES = {33071: "clamp", 33648: "mirror", 10497: "repeat"}
MAG_FILTERS = {9728: "nearest", 9729: "linear"}
MIN_FILTERS = {9728: "nearest", 9729: "linear", 9984: "mipmap", 9985: "mipmap", 9986: "mipmap", 9987: "mipmap"}
# The GLB container (glTF 2.0, section 4.4): a 12-byte header (magic, version, total length),
# then chunks of (length, type, data); the first is JSON, a second may be BIN, others are ignored.
GLB_MAGIC = b"glTF"
GLB_VERSION = 2
GLB_JSON, GLB_BIN = 0x4E4F534A, 0x004E4942
# At most this many material names in a message that lists them.
LISTED_NAMES = 12


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
    # The KHR lobes' textures this material has: (GltfTexture.name, its TextureRef).
    lobes: tuple[tuple[str, TextureRef], ...] = ()

    def lobe(self, name: str) -> TextureRef | None:
        """The lobe texture ``name`` (spec.material LOBE_TEXTURES), or None."""
        return dict(self.lobes).get(name)


@dataclass(frozen=True)
class GltfMaterials:
    materials: tuple[dict, ...]   # Material keywords, one per material
    ignored: tuple[str, ...]      # "material: what was not charted"
    textures: tuple = ()          # MaterialTextures, one per material
    files: tuple = ()             # the files beside the asset that it names (images, buffers)

    @property
    def has_textures(self) -> dict[str, bool]:
        """Which maps (sdfpbr.shading.maps) the chart composes in: those any material has a
        texture for (the ORM map: metallic-roughness or occlusion; a lobe's map: any texture
        of the lobes that goes into it)."""
        t = self.textures
        def any_of(*names):
            return any(getattr(m, n) for m in t for n in names)
        out = {"base": any_of("base_color"), "orm": any_of("metallic_roughness", "occlusion"),
               "normal": any_of("normal"), "emissive": any_of("emissive")}
        for texture in LOBE_TEXTURES:
            out[texture.map] = out.get(texture.map, False) or any(m.lobe(texture.name) for m in t)
        return out


class _Asset:
    """One asset as read: its JSON (a dict), the BIN chunk of a .glb (or None), its folder,
    its path for messages, and the bytes of the files beside it read so far."""

    def __init__(self, path: Path, doc: dict, blob):
        self.path, self.doc, self.blob, self.base = path, doc, blob, path.parent
        self.read: dict = {}

    def array(self, key: str) -> list:
        value = self.doc.get(key)
        if value is None:
            return []
        if not isinstance(value, list):
            raise SpecError(f"gltf {self.path}: {key} is not a JSON array")
        return value


def _is_index(v) -> bool:
    return type(v) is int and v >= 0


def _object(value, what: str) -> dict:
    """The JSON object ``value`` ({} where absent); a SpecError naming ``what`` otherwise."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise SpecError(f"{what} is not a JSON object")
    return value


def _glb_chunks(data: bytes, path: Path) -> tuple:
    """(the JSON chunk's bytes, the BIN chunk or None) of a GLB container."""
    def bad(why):
        return SpecError(f"gltf {path} cannot be read as glTF 2.0: {why}")
    if len(data) < 12:
        raise bad("its GLB header is cut short")
    version, length = struct.unpack_from("<II", data, 4)
    if version != GLB_VERSION:
        raise SpecError(f"gltf {path} is GLB container version {version}; sdfpbr reads GLB version {GLB_VERSION} "
                        "(glTF 2.x)")
    if length != len(data):
        raise bad(f"its GLB header gives {length} bytes; the file holds {len(data)}")
    view, chunks, at = memoryview(data), [], 12
    while at < length:
        if at + 8 > length:
            raise bad(f"GLB chunk {len(chunks)}'s header is cut short")
        size, kind = struct.unpack_from("<II", data, at)
        at += 8
        if at + size > length:
            raise bad(f"GLB chunk {len(chunks)} reaches past the file's end")
        chunks.append((kind, view[at:at + size]))
        at += size
    if not chunks or chunks[0][0] != GLB_JSON:
        raise bad("its first GLB chunk is not the JSON chunk")
    blob = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == GLB_BIN else None
    return bytes(chunks[0][1]), blob


def _load(path: Path) -> _Asset:
    """The asset at ``path``: read (bounded, a regular file), its JSON parsed (nesting bounded),
    its version and the extensions it requires checked."""
    data = read_input(path, "gltf", "gltf")
    if data[:4] == GLB_MAGIC:
        text, blob = _glb_chunks(data, path)
    elif path.suffix.lower() == ".glb":
        raise SpecError(f"gltf {path} cannot be read as glTF 2.0: it does not start with a GLB header")
    else:
        text, blob = data, None
    doc = parse_json(text, f"gltf {path} cannot be read as glTF 2.0")
    if not isinstance(doc, dict):
        raise SpecError(f"gltf {path} cannot be read as glTF 2.0: its JSON is not an object")
    asset = doc.get("asset")
    if not isinstance(asset, dict):
        raise SpecError(f"gltf {path} has no asset object (glTF 2.0 requires one, giving its version)")
    version = asset.get("version")
    if not isinstance(version, str):
        raise SpecError(f"gltf {path}: its asset.version {quote(version)} is not a string such as '2.0'")
    if version.split(".")[0] != "2":
        raise SpecError(f"gltf {path} is glTF version {quote(version)}; sdfpbr reads glTF 2.x")
    for key in ("extensionsUsed", "extensionsRequired"):
        names = doc.get(key, [])
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            raise SpecError(f"gltf {path}: {key} {quote(names)} is not a list of extension names")
    # A loader must refuse an asset that requires an extension it does not implement (glTF 2.0,
    # 3.12); HONOURED_EXTENSIONS says which sdfpbr's chart honours.
    unknown = [e for e in doc.get("extensionsRequired", []) if e not in HONOURED_EXTENSIONS]
    if unknown:
        raise SpecError(f"gltf {path} requires {quote(unknown[0])}, which sdfpbr does not chart; it reads "
                        f"{', '.join((*CHARTED_EXTENSIONS, *TEXTURE_EXTENSIONS))} and accepts the mesh "
                        f"extensions {', '.join(MESH_EXTENSIONS)}")
    return _Asset(path, doc, blob)


def _factor(value, default, what: str, length: int | None = None):
    """A number (length None) or a list of ``length`` numbers from the asset, as floats;
    ``default`` where it is absent. Anything else (a string, a boolean) is the asset's fault,
    said in one line."""
    if value is None:
        return default
    def number(v):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise SpecError(f"{what}: {quote(value)} is not {'a number' if length is None else f'{length} numbers'}")
        try:
            return float(v)
        except OverflowError:   # a whole number of 309 digits or more
            raise SpecError(f"{what}: {quote(value)} is outside glTF's range") from None
    if length is None:
        return number(value)
    if not isinstance(value, list) or len(value) != length:
        raise SpecError(f"{what}: {quote(value)} is not {length} numbers")
    return tuple(number(v) for v in value)


def _material_object(index: int, m) -> dict:
    if not isinstance(m, dict):
        raise SpecError(f"material {index} is not a JSON object")
    name = m.get("name")
    if name is not None and not isinstance(name, str):
        raise SpecError(f"material {index}: its name {quote(name)} is not a string")
    return m


def _material_name(index: int, m: dict) -> str:
    """The material's cell label: its name, or "material <index>"."""
    return m["name"] if m.get("name") else f"material {index}"


def _who(index: int, m: dict) -> str:
    """The material as messages name it: its name quoted (control characters escaped), or its
    index."""
    return f"material {quote(m['name'])}" if m.get("name") else f"material {index}"


def _extension_name(name: str) -> str:
    """An extension's name as a note shows it: as it is where it is a plain name
    (PREFIX_words), quoted otherwise."""
    return name if re.fullmatch(r"[A-Za-z0-9_]{1,64}", name) else quote(name)


def _extensions(index: int, m: dict) -> dict:
    return _object(m.get("extensions"), f"{_who(index, m)}: its extensions")


def _ignored(index: int, m: dict) -> list[str]:
    """What of material m the chart leaves out: the extensions it does not chart."""
    return [f"{_who(index, m)} {_extension_name(k)}" for k in _extensions(index, m) if k not in CHARTED_EXTENSIONS]


def _material(index: int, m: dict) -> dict:
    who = _who(index, m)
    pbr = _object(m.get("pbrMetallicRoughness"), f"{who}: pbrMetallicRoughness")
    ext = _extensions(index, m)
    values = dict(name=_material_name(index, m))

    def factor(value, default, key, length=None):
        return _factor(value, default, f"{who} {key}", length)

    def extension(key):
        return _object(ext.get(key), f"{who}: {key}")

    # The glTF defaults where a factor is absent: white, alpha 1, metallic 1, roughness 1.
    rgba = factor(pbr.get("baseColorFactor"), (1.0, 1.0, 1.0, 1.0), "baseColorFactor", 4)
    values.update(base_color=rgba[:3], alpha=rgba[3],
                  metallic=factor(pbr.get("metallicFactor"), 1.0, "metallicFactor"),
                  roughness=factor(pbr.get("roughnessFactor"), 1.0, "roughnessFactor"))
    values["emissive"] = factor(m.get("emissiveFactor"), (0.0, 0.0, 0.0), "emissiveFactor", 3)
    for lobe in LOBES:
        for e in lobe.gltf:
            if e.name in ext:
                body = extension(e.name)
                for f in e.factors:
                    size = len(f.default) if isinstance(f.default, tuple) else None
                    value = factor(body.get(f.key), f.default, f.key, size)
                    values[f.field] = f.zero_means if value == 0.0 and f.zero_means is not None else value
    mode = m.get("alphaMode")
    mode = "OPAQUE" if mode is None else mode
    if mode not in ("OPAQUE", "MASK", "BLEND"):
        raise SpecError(f"{who}: alphaMode {quote(mode)} is not OPAQUE, MASK or BLEND")
    values["alpha_cutoff"] = factor(m.get("alphaCutoff"), 0.5, "alphaCutoff")
    _check(who, values)
    values["alpha_mode"] = mode.lower()
    return values


def _check(who: str, values: dict) -> None:
    for key, value in values.items():
        if key == "name":
            continue
        for v in value if isinstance(value, tuple) else (value,):
            if not math.isfinite(v) or v < 0.0 or (key not in UNBOUNDED_FACTORS and v > 1.0):
                raise SpecError(f"{who}: {key} {quote(value)} is outside glTF's range")


def _entry(items: list, index, what: str, key: str, kind: str) -> dict:
    """items[index] for an index the asset gives under ``key``: a whole number (not a float,
    a string or a boolean) naming an existing entry, which is a JSON object (Python's negative
    indices are not glTF's)."""
    if not _is_index(index):
        raise SpecError(f"{what}: {key} {quote(index)} is not an index (a whole number >= 0)")
    if index >= len(items):
        raise SpecError(f"{what}: {key} {quote(index)} names no {kind}; the asset has {len(items)}")
    return _object(items[index], f"{what}: {kind} {index}")


def _data_uri(uri: str, what: str) -> bytes:
    import base64
    from urllib.parse import unquote_to_bytes
    header, comma, payload = uri.partition(",")
    if not comma:
        raise SpecError(f"{what}: its data URI has no ',' before its data")
    if not header.lower().endswith(";base64"):
        return unquote_to_bytes(payload)
    try:
        return base64.b64decode(payload)
    except ValueError:
        raise SpecError(f"{what}: its data URI cannot be decoded") from None


def _is_data(uri: str) -> bool:
    return uri[:5].lower() == "data:"


def _uri(owner: dict, what: str):
    uri = owner.get("uri")
    if uri is not None and not isinstance(uri, str):
        raise SpecError(f"{what}: its uri {quote(uri)} is not a string")
    return uri


def _beside_path(asset: _Asset, uri: str, what: str) -> tuple[str, Path]:
    """(the uri percent-decoded, the file it names inside the asset's folder): refused, before
    anything outside is statted, where it leads outside."""
    from urllib.parse import unquote
    name = unquote(uri)
    return name, confined(asset.base, name, what)


def _bytes_of_uri(asset: _Asset, uri: str, what: str, kind: str) -> bytes:
    """The bytes a data URI holds, or those of the file inside the asset's folder that ``uri``
    names (read as sdfpbr.inputs reads: a regular file of at most ``kind``'s size)."""
    if _is_data(uri):
        return _data_uri(uri, what)
    _, target = _beside_path(asset, uri, what)
    if target not in asset.read:
        asset.read[target] = read_input(target, f"{what}: {'image' if kind == 'image' else 'buffer'}", kind)
    return asset.read[target]


def _image_bytes(asset: _Asset, index, what: str) -> bytes:
    image = _entry(asset.array("images"), index, what, "its texture's source", "image")
    uri = _uri(image, f"{what}: image {index}")
    if uri is not None:
        return _bytes_of_uri(asset, uri, what, "image")
    if image.get("bufferView") is None:
        raise SpecError(f"{what}: image {index} has neither a uri nor a bufferView")
    view = _entry(asset.array("bufferViews"), image["bufferView"], what, "its image's bufferView", "buffer view")
    buffer = _entry(asset.array("buffers"), view.get("buffer"), what, "its buffer view's buffer", "buffer")
    uri = _uri(buffer, f"{what}: buffer {view['buffer']}")
    if uri is not None:
        blob = _bytes_of_uri(asset, uri, what, "gltf")
    elif view["buffer"] == 0 and asset.blob is not None:   # glTF: the GLB's BIN chunk is buffer 0, without a uri
        blob = asset.blob
    else:
        raise SpecError(f"{what}: buffer {view['buffer']} has no uri, and only a .glb's first buffer may omit it")
    start, length = view.get("byteOffset"), view.get("byteLength")
    start = 0 if start is None else start
    if not (_is_index(start) and _is_index(length)):
        raise SpecError(f"{what}: its buffer view's byteOffset and byteLength must be whole numbers >= 0, "
                        f"not {quote(start)} and {quote(length)}")
    if start + length > len(blob):
        raise SpecError(f"{what}: its buffer view (byteOffset {quote(start)}, byteLength {quote(length)}) reaches past "
                        f"the buffer's {len(blob)} bytes")
    return bytes(blob[start:start + length])


def _sampler_mode(sampler: dict, key: str, modes: dict, unset: str, what: str, allowed: str) -> str:
    mode = sampler.get(key)
    if mode is None:
        return unset
    if type(mode) is not int or mode not in modes:   # 9729.0 or True is no glTF enum
        raise SpecError(f"{what}: its sampler's {key} {quote(mode)} is not a glTF {allowed}")
    return modes[mode]


def _texture_ref(asset: _Asset, info, what: str, amount_key: str | None = None) -> TextureRef | None:
    """A textureInfo (a JSON object: the material's or an extension's) as a TextureRef."""
    if info is None:
        return None
    info = _object(info, what)
    texture = _entry(asset.array("textures"), info.get("index"), what, "index", "texture")
    if texture.get("source") is None:
        raise SpecError(f"{what}: its texture has no image")
    sampler = {}
    if texture.get("sampler") is not None:
        sampler = _entry(asset.array("samplers"), texture["sampler"], what, "its texture's sampler", "sampler")
    wrap_modes = ", ".join(f"{k} {v}" for k, v in WRAP_MODES.items())
    wrap = tuple(_sampler_mode(sampler, key, WRAP_MODES, "repeat", what, f"wrap mode ({wrap_modes})")
                 for key in ("wrapS", "wrapT"))
    filters = [_sampler_mode(sampler, key, modes, unset, what, f"{key} ({', '.join(str(k) for k in modes)})")
               for key, modes, unset in (("magFilter", MAG_FILTERS, "linear"), ("minFilter", MIN_FILTERS, "mipmap"))]
    extensions = _object(info.get("extensions"), f"{what}: its extensions")
    t = _object(extensions.get("KHR_texture_transform"), f"{what}: its KHR_texture_transform")
    transform = (_factor(t.get("offset"), (0.0, 0.0), f"{what} offset", 2),
                 _factor(t.get("rotation"), 0.0, f"{what} rotation"),
                 _factor(t.get("scale"), (1.0, 1.0), f"{what} scale", 2))
    amount = _factor(info.get(amount_key), 1.0, f"{what} {amount_key}") if amount_key else 1.0
    if not all(math.isfinite(v) for v in (*transform[0], transform[1], *transform[2], amount)):
        raise SpecError(f"{what}: KHR_texture_transform or its {amount_key or 'factor'} holds a non-finite number")
    return TextureRef(_image_bytes(asset, texture["source"], what), what, wrap, *filters, transform, amount)


def _textures(asset: _Asset, index: int, m: dict) -> MaterialTextures:
    who = _who(index, m)
    pbr = _object(m.get("pbrMetallicRoughness"), f"{who}: pbrMetallicRoughness")
    ext = _extensions(index, m)
    def ref(info, key, amount_key=None):
        return _texture_ref(asset, info, f"{who} {key}", amount_key)
    def ext_ref(extension, key, amount_key=None):
        e = ext.get(extension)
        return ref(e.get(key), key, amount_key) if isinstance(e, dict) else None
    return MaterialTextures(
        ref(pbr.get("baseColorTexture"), "baseColorTexture"),
        ref(pbr.get("metallicRoughnessTexture"), "metallicRoughnessTexture"),
        ref(m.get("normalTexture"), "normalTexture", "scale"),
        ref(m.get("occlusionTexture"), "occlusionTexture", "strength"),
        ref(m.get("emissiveTexture"), "emissiveTexture"),
        tuple((t.name, r) for lobe in LOBES for e in lobe.gltf for t in e.textures
              if (r := ext_ref(e.name, t.key, t.amount_key)) is not None))


# The last asset read: (path, its stat, names) -> (GltfMaterials, the files beside it that it
# names, each as (its uri decoded, the file it resolved to, mtime, size)), so that an image
# edited beside a .gltf, or a symlink there pointed elsewhere, is read again too.
_memo: dict = {}


def _beside(asset: _Asset) -> tuple:
    """(name, resolved path, mtime, size) of every file the asset's images and buffers name
    (data URIs aside). Each must lie inside the asset's folder (confined: refused before it is
    statted) and be a regular file within its kind's limit, used by a material or not (a
    gallery's key reads them all)."""
    out = []
    for key, kind in (("images", "image"), ("buffers", "gltf")):
        for i, item in enumerate(asset.array(key)):
            what = f"gltf {asset.path} {key[:-1]} {i}"
            uri = _uri(_object(item, what), what)
            if uri is None or _is_data(uri):
                continue
            name, target = _beside_path(asset, uri, what)
            check_input(target, f"{what}: file", kind)
            out.append((name, str(target), *_stat(target)))
    return tuple(out)


def _unchanged(base: Path, name: str, target: str, mtime, size) -> bool:
    """Whether a file recorded by _beside still resolves, inside ``base``, to the same file
    with the same time and size (nothing outside is statted)."""
    try:
        now = confined(base, name, "")
    except SpecError:
        return False
    return str(now) == target and _stat(now) == (mtime, size)


def _stat(path: Path) -> tuple:
    try:
        st = os.stat(path)
    except OSError:
        return (None, None)
    return (st.st_mtime_ns, st.st_size)


def _listed(names) -> str:
    names = list(names)
    shown = ", ".join(quote(n) for n in names[:LISTED_NAMES])
    return shown + (f", ... ({len(names)} in all)" if len(names) > LISTED_NAMES else "")


def gltf_materials(path: str, names: tuple[str, ...] = ()) -> GltfMaterials:
    """The materials of the asset at ``path`` (those named in ``names``, in that order; all
    without names), read once per version of the asset and of the files beside it."""
    p = check_input(path, "gltf", "gltf")   # a regular file: not a FIFO, not /dev/zero
    st = os.stat(p)
    key = (str(p.resolve()), st.st_mtime_ns, st.st_size, tuple(names))
    hit = _memo.get(key)
    if hit is None or not all(_unchanged(p.parent, *f) for f in hit[1]):
        asset = _load(p)
        beside = _beside(asset)     # before the images are read
        materials = [_material_object(i, m) for i, m in enumerate(asset.array("materials"))]
        read = [(_material(i, m), _ignored(i, m), _textures(asset, i, m)) for i, m in enumerate(materials)]
        if not read:
            raise SpecError(f"gltf {path} has no materials")
        by_name = {m["name"]: (m, ig, tx) for m, ig, tx in read}
        if names:
            missing = [n for n in names if n not in by_name]
            if missing:
                raise SpecError(f"gltf {path} has no material {quote(missing[0])}{did_you_mean(missing[0], by_name)}; "
                                f"it has: {_listed(by_name)}")
            read = [by_name[n] for n in names]
        # The files as the asset names them, beside it (not resolved: a gallery's key names
        # them relative to the asset, wherever the folder lies); each was confined above.
        files = tuple(str(p.parent / name) for name, *_ in beside)
        _memo.clear()
        _memo[key] = (GltfMaterials(tuple(m for m, _, _ in read), tuple(i for _, ig, _ in read for i in ig),
                                    tuple(tx for _, _, tx in read), files), beside)
    return _memo[key][0]


def grid_for(count: int) -> tuple[int, int]:
    """(rows, cols) with rows x cols = count, as square as whole rows allow (cols >= rows); a
    grid wider than MAX_GRID is refused here, naming the materials (not the cols it would be)."""
    rows = max(r for r in range(1, int(math.isqrt(count)) + 1) if count % r == 0)
    if count // rows > MAX_GRID:
        raise SpecError(f"the asset's {count} materials make a {rows} x {count // rows} grid, wider than "
                        f"{MAX_GRID} cells; chart some of them with --material NAME,...")
    return rows, count // rows
