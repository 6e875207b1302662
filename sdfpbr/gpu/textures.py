"""Textures for the textured spheres: a procedural set (riveted panels, or a hammered normal map
alone) or PNGs from the spec.

Conventions (glTF 2.0): colour maps (base colour, emission, sheen and specular colour) are
sRGB-encoded and sampled through sRGB textures; the ORM map (R occlusion, G roughness, B
metallic) and the normal maps are linear data; a normal map is tangent space with +X along
increasing u and +Y up (OpenGL), +Z out of the surface. The sphere's u runs once around the
vertical axis, v from the top pole (0) to the bottom (1)."""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from ..errors import SpecError
from ..image.colour import srgb_eotf, srgb_oetf
from ..shading.maps import MAPS, MAPS_BY_NAME
from ..spec.material import LOBE_TEXTURES
from .gl import upload_levels


PROCEDURAL_SIZE = (1024, 512)   # (width, height): u spans 2 pi, v spans pi, so texels stay square
GL_SRGB8_ALPHA8, GL_RGBA8 = 0x8C43, 0x8058


@dataclass(frozen=True)
class TextureSet:
    """The maps a spec composes in, by name (shading.maps): (H, W, 4) uint8 images, sRGB or
    linear as the table says; a map left out is absent (the factors stand alone).
    ``layers`` > 1: each map holds that many sphere maps stacked top to bottom, one per cell
    (a glTF asset's materials; textures.glsl reads the cell's layer). ``shared``: one object
    every render of it reuses (a procedural set, a glTF asset's bake), whose GL textures are
    kept on the context (upload_kept)."""
    images: dict
    layers: int = 1
    shared: bool = False


@lru_cache(maxsize=1)
def procedural_set() -> TextureSet:
    """Riveted panels: a 16 x 8 grid of hemispherical rivets on panels whose roughness and
    metalness alternate, so colour-space and convention bugs all show."""
    w, h = PROCEDURAL_SIZE
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    cu, cv = 16, 8
    fu, fv = (u * cu) % 1.0 - 0.5, (v * cv) % 1.0 - 0.5          # position within a panel
    x, y = np.meshgrid(fu, fv)                                    # y grows downwards (v)
    rivet_r = 0.22
    d2 = (x * x + y * y) / rivet_r**2
    inside = d2 < 1.0
    height = np.where(inside, np.sqrt(np.clip(1.0 - d2, 0.0, 1.0)), 0.0) * rivet_r
    # dh/du and dh/dv in panel units; the slope scale sets how strongly the rivets bend normals.
    with np.errstate(divide="ignore", invalid="ignore"):
        dhdx = np.where(inside, -x / np.maximum(height, 1e-3), 0.0)
        dhdy = np.where(inside, -y / np.maximum(height, 1e-3), 0.0)
    dhdx, dhdy = np.clip(dhdx, -3, 3), np.clip(dhdy, -3, 3)
    # +Y up: v grows downwards, so the up-slope component is +dh/dv.
    n = np.stack([-dhdx, dhdy, np.ones_like(dhdx)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    normal = np.rint((n * 0.5 + 0.5) * 255).astype(np.uint8)

    iu, iv = np.meshgrid(np.floor(u * cu).astype(int), np.floor(v * cv).astype(int))
    checker = (iu + iv) % 2 == 0
    occlusion = np.where(inside, 1.0, np.where(d2 < 1.6, 0.7, 1.0))     # dark ring round each rivet
    roughness = np.where(inside, 0.35, np.where(checker, 1.0, 0.55))
    metallic = np.where(inside, 1.0, np.where(checker, 1.0, 0.5))
    orm = np.rint(np.stack([occlusion, roughness, metallic], -1) * 255).astype(np.uint8)
    base = np.where(checker[..., None], 255, 214).astype(np.uint8) * np.ones(3, np.uint8)
    alpha = np.full((h, w, 1), 255, np.uint8)
    return TextureSet({"base": np.concatenate([base, alpha], -1), "orm": np.concatenate([orm, alpha], -1),
                       "normal": np.concatenate([normal, alpha], -1)})


@lru_cache(maxsize=1)
def hammered_set() -> TextureSet:
    """Hammered metal: a normal map alone (the cell's colour, roughness and metallic stand), of
    spherical dimples on a jittered 24 x 12 grid, each texel in the dimple of its nearest
    centre (a Voronoi pattern: ridges where dimples meet). Slopes reach 70 degrees 0.6 cells
    from a centre and more at the ridges, so near the silhouette many shading normals face
    away from the camera."""
    w, h = PROCEDURAL_SIZE
    cu, cv = 24, 12                                               # square cells at the equator
    rng = np.random.default_rng(12)                               # fixed: the same map every run
    centres = rng.uniform(0.15, 0.85, size=(cv, cu, 2)).astype(np.float32)   # within each cell, (u, v)
    x = ((np.arange(w) + 0.5) / w * cu).astype(np.float32)[None, :]          # texel centres in cell units
    y = ((np.arange(h) + 0.5) / h * cv).astype(np.float32)[:, None]
    best = np.full((h, w), np.inf, np.float32)
    dx, dy = np.zeros((h, w), np.float32), np.zeros((h, w), np.float32)
    for oi in (-1, 0, 1):                                         # the 3 x 3 neighbouring cells
        ci = np.floor(x).astype(int) + oi                         # wraps round in u ...
        for oj in (-1, 0, 1):
            cj = np.clip(np.floor(y).astype(int) + oj, 0, cv - 1)  # ... and stops at the poles
            centre = centres[cj, ci % cu]                          # (h, w, 2)
            ex, ey = x - (ci + centre[..., 0]), y - (cj + centre[..., 1])
            d2 = ex * ex + ey * ey
            nearer = d2 < best
            best[nearer], dx[nearer], dy[nearer] = d2[nearer], ex[nearer], ey[nearer]
    # Height -sqrt(R^2 - d^2) in cell units: slope d / sqrt(R^2 - d^2), tan 70 deg at d = 0.6.
    radius2 = 0.6 ** 2 * (1 + 1 / np.tan(np.radians(70)) ** 2)
    depth = np.sqrt(np.maximum(radius2 - best, 0.05 * radius2))
    dhdx, dhdy = dx / depth, dy / depth
    # +Y up: v grows downwards, so the up-slope component is +dh/dv (as procedural_set).
    n = np.stack([-dhdx, dhdy, np.ones_like(dhdx)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    normal = np.rint((n * 0.5 + 0.5) * 255).astype(np.uint8)
    return TextureSet({"normal": np.concatenate([normal, np.full((h, w, 1), 255, np.uint8)], -1)})


PROCEDURAL_SETS = {"procedural": procedural_set, "hammered": hammered_set}
_made: dict[str, TextureSet] = {}   # procedural sets this process has made or read


def procedural_maps(name: str, cache=None) -> TextureSet:
    """The procedural set ``name``, made once per process and kept in ``cache`` (an
    ArrayCache; None: made here): made, they cost 0.2-0.4 s of a cold process (numpy over
    512k texels), read back ~10 ms. The key covers this module's text, so a change to a
    generator makes its set again."""
    if name not in _made:
        key = None
        if cache is not None:
            from pathlib import Path

            from ..cache import content_key
            key = content_key(Path(__file__).read_bytes(), name, PROCEDURAL_SIZE)
            stored = cache.get("textures", key)
            if stored is not None and all(a.dtype == np.uint8 for a in stored.values()):
                _made[name] = TextureSet(stored, shared=True)
                return _made[name]
        _made[name] = replace(PROCEDURAL_SETS[name](), shared=True)
        if key is not None:
            cache.put("textures", key, dict(_made[name].images))
    return _made[name]


def _load_png(path: str, what: str) -> np.ndarray:
    return _rgba8(path, f"{what} {path}", "PNG")


# The largest image read: GL's usual texture limit a side, and 2^26 texels in all (256 MiB as
# RGBA8): a small file may declare a huge image, which a decoder would allocate first.
MAX_IMAGE_SIDE = 16384
MAX_IMAGE_TEXELS = 1 << 26


def _declared_size(source) -> tuple[int, int] | None:
    """The (width, height) an image file's header declares, without decoding it; None where
    Pillow cannot tell (the decoder then reports the file)."""
    import io

    from PIL import Image
    limit, Image.MAX_IMAGE_PIXELS = Image.MAX_IMAGE_PIXELS, None   # read the header, whatever it says
    try:
        with Image.open(io.BytesIO(source) if isinstance(source, bytes) else source) as im:
            return im.size
    except Exception:   # not an image Pillow knows: left to imageio's error
        return None
    finally:
        Image.MAX_IMAGE_PIXELS = limit


def _rgba8(source, what: str, kind: str = "an image") -> np.ndarray:
    """An 8-bit image file (a path or its bytes) as (H, W, 4) uint8."""
    import imageio.v3 as iio
    size = _declared_size(source)
    if size and (max(size) > MAX_IMAGE_SIDE or size[0] * size[1] > MAX_IMAGE_TEXELS):
        raise SpecError(f"{what}: the image is {size[0]}x{size[1]}; sdfpbr reads images of at most "
                        f"{MAX_IMAGE_SIDE} texels a side and {MAX_IMAGE_TEXELS} in all: scale it down")
    try:
        # Pillow's decoders only: an asset's bytes are untrusted, and imageio would otherwise
        # try every plugin it has on them (tifffile, DICOM, ffmpeg), warning as it goes.
        img = np.asarray(iio.imread(source, plugin="pillow"))
    except Exception as exc:   # imageio raises many types for unreadable files
        raise SpecError(f"{what}: cannot read it as {kind} ({exc.__class__.__name__})") from None
    if img.dtype != np.uint8:
        raise SpecError(f"{what}: {kind} with 8 bits a channel is required, got {img.dtype} (save it as 8-bit)")
    if img.ndim == 2:
        img = img[..., None]
    if img.ndim != 3 or img.shape[-1] not in (1, 2, 3, 4):
        raise SpecError(f"{what}: one still image (grey, grey+alpha, RGB or RGBA) required, "
                        f"got an array of shape {img.shape}" + (" (an animated PNG?)" if img.ndim == 4 else ""))
    if img.shape[-1] <= 2:   # grey (+ alpha): the grey in R, G and B
        img = np.concatenate([np.repeat(img[..., :1], 3, -1), img[..., 1:]], -1)
    if img.shape[-1] == 3:
        img = np.concatenate([img, np.full(img.shape[:2] + (1,), 255, np.uint8)], -1)
    return np.ascontiguousarray(img[..., :4])


# A glTF material's maps on the sphere: (width, height) of a layer; fewer texels a layer when
# many materials share the stacked map (GL's texture limit is 16384 texels a side).
GLTF_LAYER_SIZE = PROCEDURAL_SIZE
GLTF_LAYER_SIZE_MANY = (512, 256)


def _wrap(x: np.ndarray, mode: str) -> np.ndarray:
    if mode == "clamp":
        return np.clip(x, 0.0, 1.0)
    if mode == "mirror":
        t = np.mod(x, 2.0)
        return np.where(t > 1.0, 2.0 - t, t)
    return x - np.floor(x)


def _sample(img: np.ndarray, u: np.ndarray, v: np.ndarray, wrap: tuple[str, str], nearest: bool) -> np.ndarray:
    """float64 texels of ``img`` at texture coordinates (u, v) under the wrap modes, nearest
    or bilinear (on the stored values)."""
    h, w = img.shape[:2]
    x, y = _wrap(u, wrap[0]) * w - 0.5, _wrap(v, wrap[1]) * h - 0.5
    def index(i, n, mode):
        return np.mod(i, n) if mode == "repeat" else np.clip(i, 0, n - 1)
    if nearest:
        return img[index(np.floor(y + 0.5).astype(int), h, wrap[1]),
                   index(np.floor(x + 0.5).astype(int), w, wrap[0])].astype(np.float64)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    xs = [index(x0, w, wrap[0]), index(x0 + 1, w, wrap[0])]
    ys = [index(y0, h, wrap[1]), index(y0 + 1, h, wrap[1])]
    top = img[ys[0], xs[0]] * (1 - fx) + img[ys[0], xs[1]] * fx
    bottom = img[ys[1], xs[0]] * (1 - fx) + img[ys[1], xs[1]] * fx
    return top * (1 - fy) + bottom * fy


def _linear_codes(img: np.ndarray, srgb: bool) -> np.ndarray:
    """uint8 RGBA as float32 that averages right: an sRGB map's colour in linear light (codes
    0..255 scaled), alpha and a linear map's channels as they are."""
    if not srgb:
        return img.astype(np.float32)
    out = np.empty(img.shape, np.float32)
    colour = (255.0 * srgb_eotf(np.arange(256) / 255.0)).astype(np.float32)
    np.take(colour, img[..., :3], out=out[..., :3])   # a table per code, not a curve per texel
    out[..., 3:] = img[..., 3:]
    return out


def _codes(linear: np.ndarray, srgb: bool) -> np.ndarray:
    """_linear_codes' inverse, float64 codes 0..255 (not rounded)."""
    out = np.array(linear, np.float64)
    if srgb:
        out[..., :3] = 255.0 * srgb_oetf(np.clip(out[..., :3], 0.0, 255.0) / 255.0)
    return out


def _box_reduced(linear: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``linear`` (float32 (h, w, c)) at ``size`` (w, h), each texel the mean of those under it."""
    h, w = linear.shape[:2]
    if (w, h) == (size[0] * 2, size[1] * 2):   # the common step: a 2 x 2 mean in numpy
        quads = linear.reshape(size[1], 2, size[0], 2, -1)
        return ((quads[:, 0, :, 0] + quads[:, 0, :, 1]) + (quads[:, 1, :, 0] + quads[:, 1, :, 1])) * np.float32(0.25)
    from PIL import Image
    return np.stack([np.asarray(Image.fromarray(np.ascontiguousarray(linear[..., c]), "F").resize(size, Image.BOX),
                                np.float32) for c in range(linear.shape[2])], axis=-1)


def _area_reduced(img: np.ndarray, factors: tuple[float, float], srgb: bool) -> np.ndarray:
    """``img`` (uint8 RGBA) shrunk by ``factors`` (x, y) >= 1, each texel the mean of the
    texels under it (Pillow's box filter, per channel in float), colour averaged in linear light
    for an sRGB map, as a GL sRGB texture's mipmaps are; float64 codes 0..255."""
    h, w = img.shape[:2]
    size = (max(1, round(w / factors[0])), max(1, round(h / factors[1])))
    return _codes(_box_reduced(_linear_codes(img, srgb), size), srgb)


def mip_levels(img: np.ndarray, srgb: bool) -> list[np.ndarray]:
    """The mipmap levels 1.. of ``img`` (uint8 RGBA) down to 1 x 1, GL's sizes (each side
    halved, rounded down, at least 1): each texel the mean of the level-0 texels under it,
    colour in linear light for an sRGB map (as GL's sRGB mipmaps are), rounded to codes. Made
    here, not by glGenerateMipmap: the same levels on every driver, and on llvmpipe no blit
    shader compiled per format in every process (0.1 s a map)."""
    levels, linear = [], _linear_codes(img, srgb)
    w, h = img.shape[1], img.shape[0]
    while w > 1 or h > 1:
        w, h = max(1, w // 2), max(1, h // 2)
        linear = _box_reduced(linear, (w, h))
        levels.append(np.clip(np.rint(_codes(linear, srgb)), 0, 255).astype(np.uint8))
    return levels


def _on_sphere(ref, size: tuple[int, int], srgb: bool) -> np.ndarray:
    """``ref``'s image over the sphere's (u, v) texel centres, (H, W, 4) float64 in 0..255:
    KHR_texture_transform (offset, rotation, scale, with the rotation's sign as glTF-Sample-Viewer
    and the sample model read it, glTF issue 1563), then the sampler. Where a layer texel
    covers more than one image texel along an axis (its footprint, from the transform), the
    sampler minifies: ``nearest`` and ``linear`` read level 0 at the texel's centre (aliasing
    as GL would), a mipmap mode reads the image averaged over the footprint, per axis."""
    w, h = size
    u, v = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    (ox, oy), rot, (sx, sy) = ref.transform
    c, s = np.cos(rot), np.sin(rot)
    tu, tv = ox + c * sx * u + s * sy * v, oy - s * sx * u + c * sy * v
    img = _rgba8(ref.data, ref.what)
    ih, iw = img.shape[:2]
    # One layer texel's extent in image texels along the image's x and y (the transform is affine).
    footprint = ((abs(c * sx) / w + abs(s * sy) / h) * iw, (abs(s * sx) / w + abs(c * sy) / h) * ih)
    if max(footprint) <= 1.0:
        return _sample(img, tu, tv, ref.wrap, ref.mag_filter == "nearest")
    if ref.min_filter != "mipmap":
        return _sample(img, tu, tv, ref.wrap, ref.min_filter == "nearest")
    reduced = _area_reduced(img, tuple(max(1.0, f) for f in footprint), srgb)
    return _sample(reduced, tu, tv, ref.wrap, False)


def _normal_layer(ref, size: tuple[int, int]) -> np.ndarray:
    """A tangent-space normal map on the sphere, its XY scaled by glTF's normal scale."""
    n = _on_sphere(ref, size, False)[..., :3] / 255.0 * 2.0 - 1.0
    n[..., :2] *= ref.amount
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
    return (n * 0.5 + 0.5) * 255.0


def _layer(kind: str, tex, size: tuple[int, int]) -> np.ndarray:
    """One material's layer of map ``kind`` (shading.maps), its neutral value where the
    material has no texture for it (the factors stand alone)."""
    w, h = size
    out = np.empty((h, w, 4), np.float64)
    out[...] = MAPS_BY_NAME[kind].neutral
    def channel(ref, source: int, target: int):   # a texture's channel into the layer's
        if ref:
            out[..., target] = _on_sphere(ref, size, False)[..., source]
    if kind == "base":
        if tex.base_color:
            out = _on_sphere(tex.base_color, size, True)
    elif kind == "orm":
        if tex.occlusion:   # occlusion from R, scaled by its strength: 1 + s (o - 1)
            out[..., 0] = 255.0 * (1.0 + tex.occlusion.amount
                                   * (_on_sphere(tex.occlusion, size, False)[..., 0] / 255.0 - 1.0))
        if tex.metallic_roughness:   # roughness in G, metalness in B
            out[..., 1:3] = _on_sphere(tex.metallic_roughness, size, False)[..., 1:3]
    elif kind in ("normal", "emissive"):
        ref = getattr(tex, kind)
        if ref:
            out[..., :3] = _normal_layer(ref, size) if kind == "normal" else _on_sphere(ref, size, True)[..., :3]
    else:   # a lobe's map (spec.material LOBES): its textures' channels, or one colour or normal
        for texture in LOBE_TEXTURES:
            ref = tex.lobe(texture.name) if texture.map == kind else None
            if texture.kind == "channel":
                channel(ref, *texture.channel)
            elif ref and texture.kind == "normal":
                out[..., :3] = _normal_layer(ref, size)
            elif ref:
                out[..., :3] = _on_sphere(ref, size, MAPS_BY_NAME[kind].srgb)[..., :3]
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


_last_gltf_set: list = []   # [(GltfMaterials, TextureSet)]: the last asset's bake


def gltf_set(materials) -> TextureSet:
    """A glTF asset's textures as stacked layers, one per material in cell order, for the maps
    any of them has (spec.gltf.GltfMaterials). Baked once per asset version: gltf_materials
    returns the same object until the file or the names change, and every frame of an
    animation or build entry reuses its bake."""
    if _last_gltf_set and _last_gltf_set[0][0] is materials:
        return _last_gltf_set[0][1]
    size = GLTF_LAYER_SIZE if len(materials.textures) <= 16 else GLTF_LAYER_SIZE_MANY
    images = {kind: np.concatenate([_layer(kind, tex, size) for tex in materials.textures])
              for kind, present in materials.has_textures.items() if present}
    baked = TextureSet(images, layers=len(materials.textures), shared=True)
    _last_gltf_set[:] = [(materials, baked)]
    return baked


def texture_set(spec, cache=None) -> TextureSet:
    """The maps the plan composes in (shading.plan.texture_maps): the spec's PNGs where given,
    the procedural set's elsewhere (riveted or hammered; kept in ``cache``), none otherwise; a
    glTF asset's own."""
    if spec.gltf:
        return gltf_set(spec.gltf_maps())
    own = [(name, field) for name, field in (("base", "base_color_texture"), ("orm", "orm_texture"),
                                             ("normal", "normal_texture")) if getattr(spec, field)]
    if spec.textures in PROCEDURAL_SETS and not own:
        return procedural_maps(spec.textures, cache)     # the kept set itself: its upload is kept too
    images = dict(procedural_maps(spec.textures, cache).images) if spec.textures in PROCEDURAL_SETS else {}
    for name, field in own:
        images[name] = _load_png(getattr(spec, field), field)
    return TextureSet(images)


def upload(ctx, maps: TextureSet) -> dict:
    """GL textures with mipmaps for the maps present, by sampler name; colour maps through an
    sRGB format so filtering is linear. A map larger than the driver's texture limit is
    refused (GL would leave it undefined: a black sphere)."""
    import moderngl
    limit = int(ctx.info.get("GL_MAX_TEXTURE_SIZE", 16384))
    out = {}
    for kind in MAPS:
        img = maps.images.get(kind.name)
        if img is None:
            continue
        h, w = img.shape[:2]
        if max(w, h) > limit:
            for tex in out.values():
                tex.release()
            raise SpecError(f"{kind.name.replace('_', ' ')} texture is {w}x{h}; this GL takes at most "
                            f"{limit} texels a side: scale it down")
        # Image row 0 is v = 0; uploading it as the first GL row keeps texture(v) = image row v.
        kwargs = {"internal_format": GL_SRGB8_ALPHA8} if kind.srgb else {}
        tex = ctx.texture((w, h), 4, np.ascontiguousarray(img).tobytes(), **kwargs)
        if not upload_levels(ctx, tex, mip_levels(img, kind.srgb), GL_SRGB8_ALPHA8 if kind.srgb else GL_RGBA8):
            tex.build_mipmaps()
        tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        tex.repeat_x, tex.repeat_y = True, False
        out[kind.uniform] = tex
    return out


# Shared sets' GL textures kept on their context, the most recently used last: the gallery's
# textured bug pages uploaded the same procedural set with its mipmaps for every render
# (0.33 s of a build). A set of the spec's own PNGs is read for each render and uploaded anew.
KEPT_UPLOADS = 4


def upload_kept(ctx, maps: TextureSet) -> dict:
    """upload(ctx, maps) for a shared set, done once per context and kept there (the caller
    does not release them); None where the context keeps nothing (then upload and release)."""
    if not maps.shared or not isinstance(getattr(ctx, "extra", None), dict):
        return None
    kept = ctx.extra.setdefault("uploaded_maps", {})
    hit = kept.pop(id(maps), None)
    if hit is None or hit[0] is not maps:
        hit = (maps, upload(ctx, maps))
    kept[id(maps)] = hit
    while len(kept) > KEPT_UPLOADS:
        for tex in kept.pop(next(iter(kept)))[1].values():
            tex.release()
    return hit[1]
