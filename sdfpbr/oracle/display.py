"""Float64 numpy model of the display program: the tone mappers, the sRGB and gamma encodings
and the 8-bit encode, as tonemap.glsl / encode.glsl / display_main.glsl compute them.

Each tone mapper in spec/presets.py TONE_MAPPERS has its function here, ``tonemap_<glsl word>``
(x: linear RGB (..., 3); white: the white point, which only reinhard-extended reads), the twin
of its branch in tonemap.glsl (``#elif TONEMAP == <glsl word>``). The sRGB curves are
sdfpbr.image.colour's."""
from __future__ import annotations

import numpy as np

from ..image.colour import REC2020_PRIMARIES, SRGB_PRIMARIES, rgb_to_rgb_matrix, srgb_eotf, srgb_oetf
from ..spec.presets import TONE_MAPPERS, TONEMAPPERS

__all__ = [
    "TONEMAPPERS",
    "TONEMAP_CURVES",
    "TONEMAP_INPUT_MAX",
    "encode_srgb8",
    "gamma_oetf",
    "srgb_eotf",
    "srgb_half_step",
    "srgb_oetf",
    "tonemap",
]

# tonemap.glsl caps its input here (every curve is display white far below it; the ACES fits
# square x, which overflows fp32 past ~1e19). tonemap() below is the uncapped curve.
TONEMAP_INPUT_MAX = 1e4

# Stephen Hill's fit (BakingLab ACES.hlsl), written row-major: applied as M @ c.
# (The GLSL mat3 ports list these column by column.) Every row of the input matrix sums to 1;
# the published output matrix's last row sums to 0.99999, so gray stays gray to ~1e-5.
# sRGB => XYZ => D65_2_D60 => AP1 => RRT_SAT
ACES_INPUT_MAT = np.array([
    [0.59719, 0.35458, 0.04823],
    [0.07600, 0.90834, 0.01566],
    [0.02840, 0.13383, 0.83777],
])
# ODT_SAT => XYZ => D60_2_D65 => sRGB
ACES_OUTPUT_MAT = np.array([
    [1.60475, -0.53108, -0.07367],
    [-0.10208, 1.10813, -0.00605],
    [-0.00327, -0.07276, 1.07602],
])


def tonemap_none(x, white):
    return x.copy()


def tonemap_clamp(x, white):
    return np.clip(x, 0.0, 1.0)


def tonemap_reinhard(x, white):
    return x / (1.0 + x)


def tonemap_reinhard_extended(x, white):
    """Reinhard's curve with ``white`` mapped to exactly 1."""
    return x * (1.0 + x / (white * white)) / (1.0 + x)


def tonemap_aces(x, white):
    """Narkowicz's fit of the ACES filmic curve, per channel."""
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


def tonemap_aces_hill(x, white):
    c = x @ ACES_INPUT_MAT.T.astype(x.dtype)  # M @ c for each pixel
    c = (c * (c + 0.0245786) - 0.000090537) / (c * (0.983729 * c + 0.4329510) + 0.238081)
    return np.clip(c @ ACES_OUTPUT_MAT.T.astype(x.dtype), 0.0, 1.0)


def tonemap_neutral(x, white):
    """Khronos PBR Neutral (linear in, linear out)."""
    start = 0.8 - 0.04
    desat = 0.15
    m = np.min(x, axis=-1, keepdims=True)
    offset = np.where(m < 0.08, m - 6.25 * m * m, 0.04)
    c = x - offset
    peak = np.max(c, axis=-1, keepdims=True)
    d = 1.0 - start
    new_peak = 1.0 - d * d / (peak + d - start)
    safe_peak = np.where(peak < start, 1.0, peak)  # np.where evaluates both branches
    comp = c * (new_peak / safe_peak)
    g = 1.0 - 1.0 / (desat * (peak - new_peak) + 1.0)
    comp = comp * (1.0 - g) + new_peak * g
    return np.where(peak < start, c, comp)


# AgX, Troy Sobotka's, as Blender ships its base look: in Rec. 2020 primaries the inset matrix
# pulls every colour a little toward white, a log2 encoding maps 0.18 x 2^-10 .. 0.18 x 2^6.5
# onto 0..1, AgX's default contrast sigmoid turns that into a display value (it holds a 2.2
# power), and the outset matrix puts the chroma back. The matrices are Blender's (EaryChow's
# AgX LUT generator; Filament and three.js print the same numbers column by column), written
# here row-major and applied as M @ c; each row sums to 1, so grey stays grey.
AGX_INSET = np.array([
    [0.856627153315983, 0.0951212405381588, 0.0482516061458583],
    [0.137318972929847, 0.761241990602591, 0.101439036467562],
    [0.11189821299995, 0.0767994186031903, 0.811302368396859],
])
AGX_OUTSET = np.linalg.inv(np.array([   # published as its inverse
    [0.899796955911611, 0.0871996192028351, 0.013003424885555],
    [0.11142098895748, 0.875575586156966, 0.0130034248855548],
    [0.11142098895748, 0.0871996192028349, 0.801379391839686],
]))
SRGB_TO_REC2020 = rgb_to_rgb_matrix(SRGB_PRIMARIES, REC2020_PRIMARIES)
REC2020_TO_SRGB = np.linalg.inv(SRGB_TO_REC2020)
AGX_IN = AGX_INSET @ SRGB_TO_REC2020        # tonemap.glsl's srgb_to_inset
AGX_MIN_EV = np.log2(0.18) - 10.0           # the log encoding's 0 and 1: 10 stops under and
AGX_MAX_EV = np.log2(0.18) + 6.5            # 6.5 over middle grey
# The sigmoid: the least-squares polynomial fit of AgX's default contrast curve (Benjamin
# Wrensch's, three.js's), highest power first. It rises monotonically over 0..1.
AGX_SIGMOID = (15.5, -40.14, 31.96, -6.868, 0.4298, 0.1191, -0.00232)


def agx_log_encoding(x):
    """AgX's log2 encoding of a linear value: 0 at AGX_MIN_EV, 1 at AGX_MAX_EV, clipped."""
    return np.clip((np.log2(np.maximum(x, 1e-10)) - AGX_MIN_EV) / (AGX_MAX_EV - AGX_MIN_EV), 0.0, 1.0)


def tonemap_agx(x, white):
    """AgX on linear sRGB: the input clipped at 0 (in sRGB primaries, where the renderer's
    radiance is never negative), to Rec. 2020, inset, log2, sigmoid, outset, the power 2.2
    undone, back to sRGB primaries, clipped to 0..1."""
    c = np.maximum(x, 0.0) @ AGX_IN.T.astype(x.dtype)
    c = np.polyval(np.array(AGX_SIGMOID, x.dtype), agx_log_encoding(c))
    c = np.power(np.maximum(c @ AGX_OUTSET.T.astype(x.dtype), 0.0), 2.2)
    return np.clip(c @ REC2020_TO_SRGB.T.astype(x.dtype), 0.0, 1.0)


def _curve(mapper):
    curve = globals().get(f"tonemap_{mapper.glsl}")
    if curve is None:   # a row of TONE_MAPPERS without its float64 function
        raise ImportError(f"sdfpbr.oracle.display has no tonemap_{mapper.glsl} for the tone mapper {mapper.name!r}")
    return curve


# Each tone mapper's float64 function, by spec name.
TONEMAP_CURVES = {t.name: _curve(t) for t in TONE_MAPPERS}


def _apply_tonemap(x, name, white):
    if name not in TONEMAP_CURVES:
        raise ValueError(f"unknown tone mapper {name!r}; expected one of {TONEMAPPERS}")
    return TONEMAP_CURVES[name](x, white)


def tonemap(x, name, white=4.0, dtype=np.float64):
    """Tone map linear RGB (..., 3) with one of TONEMAPPERS; white only for reinhard-extended."""
    return _apply_tonemap(np.asarray(x, dtype=dtype), name, white)


def srgb_half_step(linear):
    """Half an 8-bit step of the sRGB encoding, in linear units, at each value: how far a value
    may move before its 8-bit code moves by more than half a step -- the slope of srgb_oetf
    taken at the value (the bound a table's error must stay under to be invisible). Above 1,
    where tone mapping takes over, the step at 1 relative to the value."""
    x = np.asarray(linear, dtype=np.float64)
    at = np.clip(x, 0.0, 1.0)
    slope = np.where(at <= 0.0031308, 12.92, 1.055 / 2.4 * np.power(np.maximum(at, 0.0031308), 1.0 / 2.4 - 1.0))
    half = 0.5 / 255.0 / slope
    return np.where(x > 1.0, half * np.maximum(x, 1.0), half)


def gamma_oetf(linear, gamma=2.2):
    """Pure power encoding x^(1/gamma), input clipped to [0, 1] (wrong in shadows vs sRGB)."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.power(x, 1.0 / gamma)


def encode_srgb8(linear, exposure_ev=0.0, tonemap="aces"):
    """Linear RGB -> uint8: x 2^EV, tone map, sRGB OETF, round(x * 255)."""
    x = np.asarray(linear, dtype=np.float64) * (2.0 ** exposure_ev)
    y = srgb_oetf(_apply_tonemap(x, tonemap, 4.0))
    return np.rint(y * 255.0).astype(np.uint8)
