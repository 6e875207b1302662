"""Writes docs/assets/sunset.hdr, the Radiance .hdr environment the chart guide draws with:
a low sun over a warm horizon, in plain numpy. Run from the repository root:

    python docs/_ext/make_assets.py

The file is small (128 x 64 texels, flat RGBE scanlines) and committed; this script says how
it was made. (docs/assets/materials.glb is a copy of charts/materials.glb: the docs may read
files inside the docs folder only.)
"""
from pathlib import Path

import numpy as np

WIDTH, HEIGHT = 128, 64
SUN = np.radians([150.0, 25.0])          # azimuth, elevation
SUN_RADIUS = np.radians(3.0)
SUN_RADIANCE = np.array([60.0, 42.0, 26.0])


def sky() -> np.ndarray:
    """Linear radiance (H, W, 3), row 0 at the zenith, as an equirectangular map."""
    u, v = np.meshgrid((np.arange(WIDTH) + 0.5) / WIDTH, (np.arange(HEIGHT) + 0.5) / HEIGHT)
    elevation = (0.5 - v) * np.pi
    azimuth = (u - 0.5) * 2 * np.pi
    up = np.clip(np.sin(elevation), 0.0, 1.0)[..., None]
    zenith, horizon, ground = np.array([0.15, 0.30, 0.80]), np.array([1.3, 0.75, 0.45]), np.array([0.16, 0.13, 0.11])
    out = np.where((elevation < 0)[..., None], ground, horizon + (zenith - horizon) * up ** 0.45)
    # The sun: a disc of constant radiance, by the angle to its direction.
    d = np.stack([np.cos(elevation) * np.sin(azimuth), np.sin(elevation), np.cos(elevation) * np.cos(azimuth)],
                 axis=-1)
    s = np.array([np.cos(SUN[1]) * np.sin(SUN[0]), np.sin(SUN[1]), np.cos(SUN[1]) * np.cos(SUN[0])])
    inside = np.arccos(np.clip(d @ s, -1.0, 1.0)) < SUN_RADIUS
    return np.where(inside[..., None], SUN_RADIANCE, out).astype(np.float32)


def rgbe(radiance: np.ndarray) -> bytes:
    """Flat (not run-length encoded) RGBE scanlines behind a standard header."""
    top = radiance.max(axis=-1)
    mantissa, exponent = np.frexp(top)
    scale = np.where(top > 1e-32, mantissa * 256.0 / np.maximum(top, 1e-32), 0.0)
    pixels = np.zeros(radiance.shape[:2] + (4,), np.uint8)
    pixels[..., :3] = np.clip(radiance * scale[..., None], 0, 255).astype(np.uint8)
    pixels[..., 3] = np.where(top > 1e-32, exponent + 128, 0).astype(np.uint8)
    header = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {HEIGHT} +X {WIDTH}\n".encode()
    return header + pixels.tobytes()


if __name__ == "__main__":
    out = Path(__file__).resolve().parents[1] / "assets" / "sunset.hdr"
    out.parent.mkdir(exist_ok=True)
    out.write_bytes(rgbe(sky()))
    print(out)
