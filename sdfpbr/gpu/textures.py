"""Textures for the textured spheres: a procedural set (riveted panels) or PNGs from the spec.

Conventions (glTF 2.0): base colour is sRGB-encoded and sampled through an sRGB texture; the
ORM map (R occlusion, G roughness, B metallic) and the normal map are linear data; the normal
map is tangent space with +X along increasing u and +Y up (OpenGL), +Z out of the surface.
The sphere's u runs once around the vertical axis, v from the top pole (0) to the bottom (1)."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import SpecError

PROCEDURAL_SIZE = (1024, 512)   # (width, height): u spans 2 pi, v spans pi, so texels stay square
GL_SRGB8_ALPHA8 = 0x8C43


@dataclass(frozen=True)
class TextureSet:
    """The maps a spec composes in; None: that map is absent (the factors stand alone)."""
    base_color_srgb8: np.ndarray | None   # (H, W, 4) uint8, sRGB
    orm_linear8: np.ndarray | None        # (H, W, 4) uint8, linear
    normal_linear8: np.ndarray | None     # (H, W, 4) uint8, linear, OpenGL convention


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
    return TextureSet(np.concatenate([base, alpha], -1), np.concatenate([orm, alpha], -1),
                      np.concatenate([normal, alpha], -1))


def _load_png(path: str, what: str) -> np.ndarray:
    import imageio.v3 as iio
    try:
        img = np.asarray(iio.imread(path))
    except Exception as exc:   # imageio raises many types for unreadable files
        raise SpecError(f"{what} {path}: cannot read it as PNG ({exc.__class__.__name__})") from None
    if img.dtype != np.uint8:
        raise SpecError(f"{what} {path}: 8-bit PNG required, got {img.dtype}")
    if img.ndim == 2:
        img = img[..., None]
    if img.ndim != 3 or img.shape[-1] not in (1, 2, 3, 4):
        raise SpecError(f"{what} {path}: one still image (grey, grey+alpha, RGB or RGBA) required, "
                        f"got an array of shape {img.shape}" + (" (an animated PNG?)" if img.ndim == 4 else ""))
    if img.shape[-1] <= 2:   # grey (+ alpha): the grey in R, G and B
        img = np.concatenate([np.repeat(img[..., :1], 3, -1), img[..., 1:]], -1)
    if img.shape[-1] == 3:
        img = np.concatenate([img, np.full(img.shape[:2] + (1,), 255, np.uint8)], -1)
    return np.ascontiguousarray(img[..., :4])


def texture_set(spec) -> TextureSet:
    """The maps the plan composes in (shading.plan.texture_maps): the spec's PNGs where given,
    the procedural ones elsewhere in procedural mode, none otherwise."""
    fallback = procedural_set() if spec.textures == "procedural" else TextureSet(None, None, None)
    return TextureSet(*(_load_png(getattr(spec, name), name) if getattr(spec, name) else getattr(fallback, field)
                        for name, field in (("base_color_texture", "base_color_srgb8"),
                                            ("orm_texture", "orm_linear8"),
                                            ("normal_texture", "normal_linear8"))))


def upload(ctx, maps: TextureSet) -> dict:
    """GL textures with mipmaps for the maps present; base colour through an sRGB format so
    filtering is linear. A map larger than the driver's texture limit is refused (GL would
    leave it undefined: a black sphere)."""
    import moderngl
    limit = int(ctx.info.get("GL_MAX_TEXTURE_SIZE", 16384))
    out = {}
    for name, img, fmt in (("u_base_color_map", maps.base_color_srgb8, GL_SRGB8_ALPHA8),
                           ("u_orm_map", maps.orm_linear8, None),
                           ("u_normal_map", maps.normal_linear8, None)):
        if img is None:
            continue
        h, w = img.shape[:2]
        if max(w, h) > limit:
            for tex in out.values():
                tex.release()
            raise SpecError(f"{name[2:].replace('_map', '')} texture is {w}x{h}; this GL takes at most "
                            f"{limit} texels a side: scale it down")
        # Image row 0 is v = 0; uploading it as the first GL row keeps texture(v) = image row v.
        kwargs = {"internal_format": fmt} if fmt else {}
        tex = ctx.texture((w, h), 4, np.ascontiguousarray(img).tobytes(), **kwargs)
        tex.build_mipmaps()
        tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        tex.repeat_x, tex.repeat_y = True, False
        out[name] = tex
    return out
