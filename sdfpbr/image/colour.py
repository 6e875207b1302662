"""Colour, written once: the sRGB transfer functions, Rec. 709 luminance, the RGB <-> XYZ
matrices made from a colour space's primaries, and the chart's page colour.

Production code (texture filtering, label contrast, the GPU's page uniform) and the float64
oracles (sdfpbr.oracle.display) read them from here; shaders/encode.glsl is the GLSL twin of
srgb_oetf."""
from __future__ import annotations

import numpy as np

__all__ = [
    "BACKGROUND",
    "D65_WHITE",
    "REC709_LUMINANCE",
    "REC2020_PRIMARIES",
    "SRGB_PRIMARIES",
    "luminance",
    "rgb_to_rgb_matrix",
    "rgb_to_xyz_matrix",
    "srgb_eotf",
    "srgb_oetf",
]

BACKGROUND = (24, 24, 24, 255)   # the page of charts, sheets and heat maps (sRGB, 8-bit RGBA)

# Y of linear Rec. 709 / sRGB RGB (the middle row of rgb_to_xyz_matrix(SRGB_PRIMARIES), rounded
# to 4 places as IEC 61966-2-1 and WCAG write it).
REC709_LUMINANCE = (0.2126, 0.7152, 0.0722)

# CIE 1931 xy chromaticities of the red, green and blue primaries, and of the white point.
SRGB_PRIMARIES = ((0.64, 0.33), (0.30, 0.60), (0.15, 0.06))          # ITU-R BT.709
REC2020_PRIMARIES = ((0.708, 0.292), (0.170, 0.797), (0.131, 0.046))  # ITU-R BT.2020
D65_WHITE = (0.3127, 0.3290)


def srgb_oetf(linear, dtype=np.float64):
    """Piecewise sRGB encoding (IEC 61966-2-1), input clipped to [0, 1]."""
    x = np.clip(np.asarray(linear, dtype=dtype), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_eotf(encoded):
    """Piecewise sRGB decoding, input clipped to [0, 1]."""
    y = np.clip(np.asarray(encoded, dtype=np.float64), 0.0, 1.0)
    return np.where(y <= 0.04045, y / 12.92, np.power((y + 0.055) / 1.055, 2.4))


def luminance(linear):
    """Relative luminance Y of linear sRGB (..., 3)."""
    return np.asarray(linear, np.float64)[..., :3] @ np.array(REC709_LUMINANCE)


def _xyz(xy) -> np.ndarray:
    x, y = xy
    return np.array([x / y, 1.0, (1.0 - x - y) / y])


def rgb_to_xyz_matrix(primaries, white=D65_WHITE) -> np.ndarray:
    """The 3 x 3 matrix M with XYZ = M @ rgb for linear RGB in a space with these primaries,
    scaled so that rgb (1, 1, 1) is the white point at Y = 1 (SMPTE RP 177)."""
    columns = np.stack([_xyz(p) for p in primaries], axis=1)
    return columns * np.linalg.solve(columns, _xyz(white))


def rgb_to_rgb_matrix(source, target, white=D65_WHITE) -> np.ndarray:
    """The matrix M with rgb_target = M @ rgb_source, for two spaces with the same white."""
    return np.linalg.solve(rgb_to_xyz_matrix(target, white), rgb_to_xyz_matrix(source, white))
