"""Every cell's material as the chart's programs read it (material.glsl): one row of
TEXELS_PER_CELL RGBA float texels per cell, row index = grid row * cols + column.

Texel layout (material.glsl reads it; change both together):
  0: base colour (linear), metallic
  1: perceptual roughness, clearcoat, clearcoat roughness, sheen roughness
  2: sheen colour (linear), alpha
  3: f0(ior) x specular colour (the shader clamps it to 1 after a specular colour map), specular weight
  4: emission = emissive colour x emissive strength, alpha test (ALPHA_TEST below)
"""
from __future__ import annotations

import numpy as np

from ..spec.material import Material, dielectric_f0

TEXELS_PER_CELL = 5
# How material.glsl's sphere_alpha reads a cell's alpha: opaque, blend, or mask with the
# cutoff itself (>= 0) as the code.
ALPHA_TEST = {"opaque": -2.0, "blend": -1.0}


def alpha_test(material: Material) -> float:
    return ALPHA_TEST.get(material.alpha_mode, material.alpha_cutoff)


def cell_texels(material: Material) -> np.ndarray:
    """(TEXELS_PER_CELL, 4) float64 for one material."""
    m = material
    return np.array([
        [*m.base_color, m.metallic],
        [m.roughness, m.clearcoat, m.clearcoat_roughness, m.sheen_roughness],
        [*m.sheen_color, m.alpha],
        [*(dielectric_f0(m.ior) * np.asarray(m.specular_color)), m.specular],
        [*(np.asarray(m.emissive) * m.emissive_strength), alpha_test(m)],
    ], np.float64)


def material_table(cells: list[list[Material]]) -> np.ndarray:
    """(rows * cols, TEXELS_PER_CELL, 4) float32: the texture's rows, cell by cell."""
    return np.stack([cell_texels(m) for row in cells for m in row]).astype(np.float32)


def upload(ctx, table: np.ndarray):
    """``material_table``'s table as a texture (nearest, clamped: read with texelFetch)."""
    import moderngl
    table = np.ascontiguousarray(table)
    tex = ctx.texture((TEXELS_PER_CELL, table.shape[0]), 4, table.tobytes(), dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    tex.repeat_x = tex.repeat_y = False
    return tex
