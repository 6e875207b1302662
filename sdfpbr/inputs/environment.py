"""Environment files: an equirectangular map (.npy, .exr or Radiance .hdr) read as float32
radiance, checked, and fitted to the GL's largest texture. gpu.ibl uploads and bakes what
this returns."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import SpecError
from . import check_input, printable, read_input


MAX_ENV_TEXELS = 1 << 28       # 16384 x 16384: beyond this an environment file is refused
MAX_ENV_RADIANCE = 1e30        # finite but larger values overflow the bakes' float32 sums


def load_env_file(path: str | Path) -> np.ndarray:
    """An equirectangular environment (.npy, .exr or Radiance .hdr) as float32 (H, W, 3), row 0
    at the zenith. Real numbers only (integer or float dtypes), at most MAX_ENV_TEXELS texels
    and MAX_ENV_RADIANCE; read lazily, so a header claiming a huge array is refused before
    anything is allocated."""
    path = check_input(path, "environment", "environment")   # a regular file, not a FIFO or device
    suffix = path.suffix.lower()
    if suffix == ".hdr":   # RGBE, decoded here (inputs.rgbe): its header is checked before its pixels
        from .rgbe import RGBEError, read_rgbe
        try:
            raw = read_input(path, "environment", "environment")
            data = read_rgbe(raw, MAX_ENV_TEXELS)
        except RGBEError as exc:
            raise SpecError(printable(f"cannot read environment {path} as a Radiance .hdr (RGBE) "
                                      f"image: {exc}")) from None
    elif suffix == ".npy":
        try:
            data = np.load(path, mmap_mode="r")   # allow_pickle stays off: a pickle is refused, not run
        except (OSError, ValueError, EOFError) as exc:
            raise SpecError(f"cannot read environment {path} as an H x W x 3 array of radiance in .npy "
                            f"(numpy: {str(exc).splitlines()[0]})") from None
    else:
        try:
            import OpenEXR
        except ImportError:
            from ..extras import missing_extra
            raise missing_extra("exr", "reading .exr environments", "or give a .hdr or .npy file") from None
        _check_exr_size(path)
        try:
            with OpenEXR.File(str(path)) as f:
                channels = f.channels()
                if "RGB" in channels:
                    data = channels["RGB"].pixels
                elif "RGBA" in channels:
                    data = channels["RGBA"].pixels[..., :3]
                else:
                    data = np.stack([channels[c].pixels for c in "RGB"], axis=-1)
        except Exception as exc:
            raise SpecError(f"cannot read environment {path} as an OpenEXR image with R, G and B "
                            f"channels ({exc})") from None
    if not isinstance(data, np.ndarray) or data.dtype.kind not in "iuf":
        kind = getattr(data, "dtype", type(data))
        raise SpecError(f"environment {path} must hold real numbers (integer or float), got {kind}")
    if data.ndim != 3 or data.shape[2] < 3 or data.shape[0] < 2 or data.shape[1] < 2:
        raise SpecError(f"environment {path} must be an H x W x 3 image, got shape {data.shape}")
    if data.shape[0] * data.shape[1] > MAX_ENV_TEXELS:
        raise SpecError(f"environment {path} is {data.shape[1]}x{data.shape[0]}; at most "
                        f"{MAX_ENV_TEXELS} texels (16384 x 16384) are read: scale it down")
    data = np.asarray(data[..., :3], dtype=np.float32)
    if not np.all(np.isfinite(data)) or data.min() < 0 or data.max() > MAX_ENV_RADIANCE:
        raise SpecError(f"environment {path} has negative, NaN, Inf or over-1e30 values")
    return np.ascontiguousarray(data)


def _check_exr_size(path: Path) -> None:
    """Refuse an OpenEXR file whose header declares more than MAX_ENV_TEXELS, before its
    pixels are decoded (a small file may declare a huge image)."""
    import OpenEXR
    try:
        with OpenEXR.File(str(path), header_only=True) as f:
            low, high = f.header()["dataWindow"]
        width, height = int(high[0]) - int(low[0]) + 1, int(high[1]) - int(low[1]) + 1
    except Exception as exc:   # the library raises its own types for a bad file
        raise SpecError(f"cannot read environment {path} as an OpenEXR image ({exc})") from None
    if width * height > MAX_ENV_TEXELS:
        raise SpecError(f"environment {path} is {width}x{height}; at most {MAX_ENV_TEXELS} texels "
                        f"(16384 x 16384) are read: scale it down")


def fit_texture(data: np.ndarray, limit: int) -> np.ndarray:
    """``data`` (H, W, C) with each side longer than ``limit`` texels area-averaged down to
    ``limit`` (GL leaves a larger texture undefined: an all-black environment). Only a long
    side shrinks: a 2 x 100000 environment becomes 2 x 16384, never 0 rows (a lat-long map is
    sampled by its (u, v), whatever its aspect). The mean radiance is kept exactly."""
    for axis in (0, 1):
        n = data.shape[axis]
        if n > limit:
            d = np.moveaxis(data, axis, 0).astype(np.float64)
            # Output texel i covers input [i n / limit, (i + 1) n / limit): the integral of
            # the piecewise-constant input over it, from its running sum, over its width.
            running = np.concatenate([np.zeros((1, *d.shape[1:])), np.cumsum(d, axis=0)], axis=0)
            edges = np.arange(limit + 1) * (n / limit)
            whole = np.minimum(np.floor(edges).astype(np.int64), n - 1)
            part = (edges - whole).reshape(-1, *([1] * (d.ndim - 1)))
            integral = running[whole] + part * d[whole]
            out = (integral[1:] - integral[:-1]) * (limit / n)
            data = np.ascontiguousarray(np.moveaxis(out, 0, axis).astype(np.float32))
    return data
