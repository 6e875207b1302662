"""Float64 numpy model of the display program: the tone mappers, the sRGB and gamma encodings
and the 8-bit encode, as tonemap.glsl / encode.glsl / display_main.glsl compute them.
See shared/REFERENCE.md for the curves and test vectors."""
from __future__ import annotations

import numpy as np

from ..spec.presets import TONEMAPPERS

__all__ = ["TONEMAPPERS", "TONEMAP_INPUT_MAX", "tonemap", "srgb_oetf", "srgb_eotf", "gamma_oetf", "encode_srgb8"]

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

def _aces_narkowicz(x):
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


def _aces_hill(x):
    c = x @ ACES_INPUT_MAT.T.astype(x.dtype)  # M @ c for each pixel
    c = (c * (c + 0.0245786) - 0.000090537) / (c * (0.983729 * c + 0.4329510) + 0.238081)
    return np.clip(c @ ACES_OUTPUT_MAT.T.astype(x.dtype), 0.0, 1.0)


def _pbr_neutral(x):
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


def _apply_tonemap(x, name, white=4.0, dtype=np.float64):
    x = np.asarray(x, dtype=dtype)
    if name == "none":
        return x.copy()
    if name == "clamp":
        return np.clip(x, 0.0, 1.0)
    if name == "reinhard":
        return x / (1.0 + x)
    if name == "reinhard-extended":
        return x * (1.0 + x / (white * white)) / (1.0 + x)
    if name == "aces":
        return _aces_narkowicz(x)
    if name == "aces-hill":
        return _aces_hill(x)
    if name == "neutral":
        return _pbr_neutral(x)
    raise ValueError(f"unknown tone mapper {name!r}; expected one of {TONEMAPPERS}")


def tonemap(x, name, white=4.0, dtype=np.float64):
    """Tone map linear RGB (..., 3) with one of TONEMAPPERS; white only for reinhard-extended."""
    return _apply_tonemap(x, name, white=white, dtype=dtype)


def srgb_oetf(linear, dtype=np.float64):
    """Piecewise sRGB encoding (IEC 61966-2-1), input clipped to [0, 1]."""
    x = np.clip(np.asarray(linear, dtype=dtype), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_eotf(encoded):
    """Piecewise sRGB decoding, input clipped to [0, 1]."""
    y = np.clip(np.asarray(encoded, dtype=np.float64), 0.0, 1.0)
    return np.where(y <= 0.04045, y / 12.92, np.power((y + 0.055) / 1.055, 2.4))


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
    y = srgb_oetf(_apply_tonemap(x, tonemap))
    return np.rint(y * 255.0).astype(np.uint8)
