"""Error metrics between a render and its reference, and error heat maps.

* ``rel_rmse``: relative RMSE in linear HDR (Rousselle et al. 2011's relMSE, square-rooted),
  over sphere pixels or any mask; ``per_cell_rel_rmse`` per sphere of the chart.
* ``flip_ldr`` / ``flip_hdr``: NVIDIA's LDR- and HDR-FLIP, computed by ``image/flip.py`` (numpy;
  flip-evaluator's maps within a stated tolerance at a fifth of its CPU time). Every input is
  checked here first: a bad one raises SpecError in one line.
* ``per_cell_mean``: the mean of any per-pixel error map per sphere cell.
* ``heatmap_image``: an error map as an RGBA image with a labeled colour bar (numpy + Pillow);
  ``heatmap`` also says where in that image it put the map.
"""
from __future__ import annotations

import functools
import hashlib
import weakref

from dataclasses import dataclass

import numpy as np

from ..errors import SpecError
from ..result_cache import ResultCache

DEFAULT_EPS = 1e-2          # relMSE's guard against division by ~0 (Rousselle et al. use 0.01)
DEFAULT_PPD = 67.0          # FLIP's default: 0.7 m from a 0.7 m wide 3840-pixel monitor
_NAN_COLOR = (48, 48, 48)   # heat-map pixels outside the evaluated region


# ---------------------------------------------------------------------------------------------
# Input checks: one line that names the argument and what is allowed.

def _image(a, what: str, *, ldr: bool = False) -> np.ndarray:
    """(H, W, 3) from (H, W, 3|4) input, alpha dropped: float32, or for LDR uint8 as given (a
    quarter of the bytes to hash and to send to a worker; _evaluate scales it to [0, 1])."""
    try:
        arr = np.asarray(a)
    except Exception:
        raise SpecError(f"{what} must be an image array, got {type(a).__name__}") from None
    if arr.ndim != 3 or arr.shape[2] not in (3, 4):
        raise SpecError(f"{what} must have shape (H, W, 3) or (H, W, 4), got {arr.shape}")
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise SpecError(f"{what} is empty, shape {arr.shape}")
    arr = arr[..., :3]
    if arr.dtype == np.uint8 and ldr:
        return np.ascontiguousarray(arr)
    if arr.dtype.kind != "f":
        allowed = "uint8 or float in [0, 1]" if ldr else "float (linear radiance)"
        raise SpecError(f"{what} has dtype {arr.dtype}; allowed: {allowed}")
    arr = arr.astype(np.float32)
    if not np.isfinite(arr).all():
        raise SpecError(f"{what} contains NaN or infinite values")
    if ldr and (arr.min() < 0.0 or arr.max() > 1.0):
        raise SpecError(f"{what} is a float LDR image with values outside [0, 1] "
                        f"({arr.min():g}..{arr.max():g}); pass sRGB-encoded values in [0, 1] or uint8")
    if not ldr and arr.min() < 0.0:
        raise SpecError(f"{what} has negative radiance ({arr.min():g}); HDR FLIP needs values >= 0")
    return np.ascontiguousarray(arr)


def _same_size(test: np.ndarray, ref: np.ndarray) -> None:
    if test.shape[:2] != ref.shape[:2]:
        raise SpecError(f"test image is {test.shape[1]}x{test.shape[0]} but the reference is "
                        f"{ref.shape[1]}x{ref.shape[0]}; they must match")


def _mask(mask, shape: tuple[int, int]) -> np.ndarray:
    """None: every pixel. A dict: an AOV dict, sphere pixels (row >= 0). Else a bool array."""
    if mask is None:
        return np.ones(shape, bool)
    if isinstance(mask, dict):
        if "row" not in mask:
            raise SpecError("mask given as an AOV dict must have a 'row' entry")
        mask = sphere_mask(mask)
    m = np.asarray(mask)
    if m.dtype != bool:
        raise SpecError(f"mask must be a boolean array, got dtype {m.dtype}")
    if m.shape != tuple(shape):
        raise SpecError(f"mask has shape {m.shape}, the images are {shape}")
    if not m.any():
        raise SpecError("mask selects no pixels")
    return m


def sphere_mask(aov: dict) -> np.ndarray:
    """Pixels that show a sphere, from a render's AOVs."""
    row = np.asarray(aov["row"])
    mask = row >= 0
    if "col" in aov:
        mask &= np.asarray(aov["col"]) >= 0
    return mask


def _cells(aov_row, aov_col, rows: int, cols: int, shape) -> tuple[np.ndarray, np.ndarray]:
    """Flat cell index (row * cols + col) per pixel and the validity mask."""
    r, c = np.asarray(aov_row), np.asarray(aov_col)
    if r.shape != tuple(shape) or c.shape != tuple(shape):
        raise SpecError(f"aov row/col have shapes {r.shape}/{c.shape}, the map is {tuple(shape)}")
    if not (isinstance(rows, (int, np.integer)) and isinstance(cols, (int, np.integer)) and rows > 0 and cols > 0):
        raise SpecError(f"rows and cols must be positive whole numbers, got {rows!r}, {cols!r}")
    r = np.rint(r).astype(np.int64)
    c = np.rint(c).astype(np.int64)
    valid = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
    return np.where(valid, r * cols + c, 0), valid


def _cell_mean(values: np.ndarray, index: np.ndarray, valid: np.ndarray, rows: int, cols: int) -> np.ndarray:
    ok = valid & np.isfinite(values)
    n = np.bincount(index[ok], minlength=rows * cols)
    s = np.bincount(index[ok], weights=values[ok].astype(np.float64), minlength=rows * cols)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, s / np.maximum(n, 1), np.nan).reshape(rows, cols)


# ---------------------------------------------------------------------------------------------
# Relative RMSE in linear HDR.

def rel_sq_error(test_linear, ref_linear, eps: float = DEFAULT_EPS) -> np.ndarray:
    """Per-pixel relative squared error, averaged over R, G, B: ((t - r)^2 / (r^2 + eps))."""
    t = _image(test_linear, "test image")
    r = _image(ref_linear, "reference image")
    _same_size(t, r)
    if not (isinstance(eps, (int, float)) and eps > 0):
        raise SpecError(f"eps must be a positive number, got {eps!r}")
    t64, r64 = t.astype(np.float64), r.astype(np.float64)
    return ((t64 - r64) ** 2 / (r64 ** 2 + eps)).mean(axis=2)


def rel_rmse(test_linear, ref_linear, mask=None, eps: float = DEFAULT_EPS) -> float:
    """Relative RMSE: sqrt(mean over masked pixels and RGB of (t - r)^2 / (r^2 + eps)).

    This is the square root of the relMSE of Rousselle, Knaus and Zwicker (2011), the usual
    error measure for Monte Carlo renders: a 10% error reads ~0.1 whether the pixel is dim or
    bright, and ``eps`` keeps near-black reference pixels from dominating. ``mask``: None (all
    pixels), a boolean (H, W) array, or an AOV dict (sphere pixels: row >= 0 and col >= 0)."""
    err = rel_sq_error(test_linear, ref_linear, eps)
    m = _mask(mask, err.shape)
    return float(np.sqrt(err[m].mean()))


def per_cell_rel_rmse(test_linear, ref_linear, aov_row, aov_col, rows: int, cols: int,
                      eps: float = DEFAULT_EPS) -> np.ndarray:
    """(rows, cols) relative RMSE of each sphere; NaN for a sphere with no visible pixel."""
    err = rel_sq_error(test_linear, ref_linear, eps)
    index, valid = _cells(aov_row, aov_col, rows, cols, err.shape)
    return np.sqrt(_cell_mean(err, index, valid, rows, cols))


def per_cell_mean(error_map, aov_row, aov_col, rows: int, cols: int) -> np.ndarray:
    """(rows, cols) mean of a per-pixel error map (e.g. FLIP) over each sphere's pixels."""
    e = np.asarray(error_map, dtype=np.float64)
    if e.ndim == 3 and e.shape[2] == 1:
        e = e[..., 0]
    if e.ndim != 2:
        raise SpecError(f"error map must have shape (H, W), got {e.shape}")
    index, valid = _cells(aov_row, aov_col, rows, cols, e.shape)
    return _cell_mean(e, index, valid, rows, cols)


# ---------------------------------------------------------------------------------------------
# FLIP (image/flip.py).

def _ppd(pixels_per_degree) -> float:
    if pixels_per_degree is None:
        return DEFAULT_PPD
    if isinstance(pixels_per_degree, bool) or not isinstance(pixels_per_degree, (int, float)) \
            or not np.isfinite(pixels_per_degree) or pixels_per_degree <= 0:
        raise SpecError(f"pixels_per_degree must be a positive number, got {pixels_per_degree!r}")
    return float(pixels_per_degree)


# FLIP results a process keeps by content: a gallery's per-bug pages and its catalog measure the
# same pairs (0.2 s each at 512² on two cores); hashing a pair costs ~1 % of that.
KEPT_FLIP_BYTES = 64 << 20
_kept_flips = ResultCache(KEPT_FLIP_BYTES, lambda kept: kept[1].nbytes)   # key -> (mean, error map)


# Measured pairs are also stored on disk by the same content key (the cache's "flip" kind; the
# key names the implementation that measures): a gallery whose renders did not change
# re-measures none of its 22 bug pairs when only the Python that lays out its pages did. The map
# is stored as measured (float32): a stored pair gives the very image a fresh measurement gives.
FLIP_CACHE_KIND = "flip"


def _stored_key(key: str) -> str:
    return hashlib.sha256(key.encode()).hexdigest()


def _stored(key: str) -> tuple[float, np.ndarray] | None:
    from ..cache import ArrayCache
    arrays = ArrayCache().get(FLIP_CACHE_KIND, _stored_key(key))
    if arrays is None or set(arrays) != {"mean", "map"}:
        return None
    return float(arrays["mean"]), arrays["map"]


def _store(key: str, kept: tuple[float, np.ndarray]) -> None:
    from ..cache import ArrayCache
    ArrayCache().put(FLIP_CACHE_KIND, _stored_key(key), {"mean": np.float64(kept[0]), "map": kept[1]})


# Keys of LDR pairs given as read-only arrays (the sheets' kept renders), by the arrays'
# identity: a gallery asks for each pair three times (submitted, its page, the catalog), and
# checking and hashing two 512² images each time was a tenth of the catalog's composition.
# The arrays are held weakly (an animation's frames must not stay alive for this), and an
# entry counts only while both are the very objects it was made for (ids are reused).
_keys_of_arrays: dict = {}   # (id(test), id(ref), ppd) -> (weakref to test, to ref, key)


def _known_key(test, ref, ppd: float) -> str | None:
    hit = _keys_of_arrays.get((id(test), id(ref), ppd))
    return hit[2] if hit is not None and hit[0]() is test and hit[1]() is ref else None


def _remember_key(test, ref, ppd: float, key: str) -> None:
    if (isinstance(test, np.ndarray) and isinstance(ref, np.ndarray)
            and not (test.flags.writeable or ref.flags.writeable)):
        if len(_keys_of_arrays) >= 256:
            for k in [k for k, (t, r, _) in _keys_of_arrays.items() if t() is None or r() is None]:
                del _keys_of_arrays[k]
            if len(_keys_of_arrays) >= 256:
                _keys_of_arrays.clear()
        _keys_of_arrays[(id(test), id(ref), ppd)] = (weakref.ref(test), weakref.ref(ref), key)


def _flip_key(ref: np.ndarray, test: np.ndarray, mode: str, parameters: dict) -> str:
    from .flip import implementation_id
    digest = hashlib.sha256()
    for array in (ref, test):
        digest.update(repr((array.shape, array.dtype.str)).encode())
        digest.update(np.ascontiguousarray(array).data)
    return f"{digest.hexdigest()} {mode} {sorted(parameters.items())} {implementation_id()}"


def _evaluate(ref: np.ndarray, test: np.ndarray, mode: str, parameters: dict) -> tuple[float, np.ndarray]:
    """FLIP of checked inputs: (mean, (H, W) float32 error map). Module level: a FlipBatch's
    workers run it."""
    from .flip import hdr_flip, ldr_flip
    if mode == "LDR":
        error_map = ldr_flip(ref, test, parameters["ppd"])
    else:     # a black reference is measured at one exposure (flip.hdr_exposures)
        error_map, _ = hdr_flip(ref, test, parameters["ppd"])
    return float(error_map.mean(dtype=np.float64)), error_map


def _flip(ref: np.ndarray | None, test: np.ndarray | None, mode: str, parameters: dict, mask,
          key: str | None = None) -> tuple[float, np.ndarray]:
    """The pair's (mean, map), kept; ``key`` given: the pair's, and ref and test may be None
    where it is kept or in flight."""
    m = None if mask is None or ref is None else _mask(mask, ref.shape[:2])   # checked before any work
    key = key or _flip_key(ref, test, mode, parameters)
    kept = _kept_flips.get(key)
    if kept is None:
        kept = _collect(key)
        if kept is None:
            kept = _stored(key)
        if kept is None:
            if ref is None:   # flip_ldr looked first; only another thread's eviction gets here
                raise RuntimeError("a pair known by its key alone is neither kept nor in flight")
            kept = _evaluate(ref, test, mode, parameters)
            _store(key, kept)
        _kept_flips.put(key, kept)
    mean, error_map = kept
    if mask is not None and m is None:
        m = _mask(mask, error_map.shape)
    error_map = error_map.copy()   # the kept one stays as measured
    if m is not None:
        mean = error_map[m].mean(dtype=np.float64)
    return float(mean), error_map


def flip_ldr(test_srgb8, ref_srgb8, pixels_per_degree: float | None = None, mask=None) -> tuple[float, np.ndarray]:
    """LDR-FLIP of two display images: uint8 sRGB (or floats in [0, 1], sRGB-encoded), (H, W, 3|4),
    alpha ignored. Returns (mean error, (H, W) float32 map in [0, 1]); the mean is over the whole
    image, or over ``mask`` (bool array or AOV dict) when given."""
    ppd = _ppd(pixels_per_degree)
    key = _known_key(test_srgb8, ref_srgb8, ppd)
    if key is not None and (key in _in_flight or _kept_flips.get(key) is not None):
        return _flip(None, None, "LDR", {"ppd": ppd}, mask, key)   # taken by its key
    test = _image(test_srgb8, "test image", ldr=True)
    ref = _image(ref_srgb8, "reference image", ldr=True)
    _same_size(test, ref)
    key = _flip_key(ref, test, "LDR", {"ppd": ppd})
    _remember_key(test_srgb8, ref_srgb8, ppd, key)
    return _flip(ref, test, "LDR", {"ppd": ppd}, mask, key)


def flip_hdr(test_linear, ref_linear, pixels_per_degree: float | None = None, mask=None) -> tuple[float, np.ndarray]:
    """HDR-FLIP of two linear-radiance images (float, >= 0, (H, W, 3|4)); FLIP picks its exposure
    range from the reference. Returns (mean error, (H, W) float32 map)."""
    test = _image(test_linear, "test image")
    ref = _image(ref_linear, "reference image")
    _same_size(test, ref)
    return _flip(ref, test, "HDR", {"ppd": _ppd(pixels_per_degree)}, mask)


# A 512² pair takes ~0.12 s of one core (image/flip.py). Helper processes (workers.helpers)
# measure the pairs beside the renders of the next ones: a thread cannot, as the GL calls hold
# the GIL while llvmpipe draws (22 pairs measured in a thread lagged the renders by 2-2.6 s; in 2
# processes by 0.2 s, and `compare --bugs all` took 7.2-8.2 s against 8.9-9.3).


# Pairs an open FlipBatch is measuring in its workers: key -> future. flip_ldr of such a pair
# waits for its worker rather than measuring it again.
_in_flight: dict = {}


def _collect(key: str) -> tuple[float, np.ndarray] | None:
    """The result of an in-flight pair (None if there is none, or its worker died)."""
    from concurrent.futures import CancelledError
    from concurrent.futures.process import BrokenProcessPool
    future = _in_flight.pop(key, None)
    if future is None:
        return None
    try:
        kept = future.result()
    except (BrokenProcessPool, CancelledError):
        return None
    _store(key, kept)
    return kept


class FlipBatch:
    """LDR-FLIPs of many pairs, measured in worker processes while the caller goes on (renders
    the next pair, or other images): ``submit`` each pair inside the ``with`` block; flip_ldr
    of a submitted pair, in the block or after it, takes its result (waiting for its worker if
    need be), and on leaving the block every result is kept (within KEPT_FLIP_BYTES).
    ``expected``: how many pairs will come (few pairs, one core, or workers that cannot start:
    each pair is measured in-process as it is submitted; a pair whose worker died is measured
    by flip_ldr when asked)."""

    def __init__(self, expected: int):
        from ..workers import helpers
        self._workers = helpers(expected)   # none in a helper: its parent's helpers have the cores
        self._pool = None
        self._futures: dict = {}    # key -> the pair's result from a worker

    def __enter__(self) -> "FlipBatch":
        return self

    @property
    def workers(self) -> int:
        """Worker processes measuring (0: in-process)."""
        return self._workers

    def submit(self, test_srgb8, ref_srgb8, pixels_per_degree: float | None = None) -> None:
        ppd = _ppd(pixels_per_degree)
        key = _known_key(test_srgb8, ref_srgb8, ppd)
        if key is not None and (key in _in_flight or _kept_flips.get(key) is not None):
            return
        test = _image(test_srgb8, "test image", ldr=True)
        ref = _image(ref_srgb8, "reference image", ldr=True)
        _same_size(test, ref)
        args = (ref, test, "LDR", {"ppd": ppd})
        key = _flip_key(*args)
        _remember_key(test_srgb8, ref_srgb8, ppd, key)
        if key in _in_flight or _kept_flips.get(key) is not None:
            return
        stored = _stored(key)
        if stored is not None:
            _kept_flips.put(key, stored)
            return
        if self._workers:
            try:
                if self._pool is None:
                    from ..workers import process_pool
                    self._pool = process_pool(self._workers)
                _in_flight[key] = self._futures[key] = self._pool.submit(_evaluate, *args)
                return
            except (OSError, RuntimeError):   # no processes to be had: measure here
                self._workers = 0
        kept = _evaluate(*args)
        _store(key, kept)
        _kept_flips.put(key, kept)

    def __exit__(self, kind, value, traceback) -> None:
        try:
            if kind is None:
                for key in self._futures:
                    if key in _in_flight:   # not yet taken by flip_ldr
                        kept = _collect(key)
                        if kept is not None:   # None: its worker died; flip_ldr measures it when asked
                            _kept_flips.put(key, kept)
        finally:
            for key in self._futures:
                _in_flight.pop(key, None)
            if self._pool is not None:
                self._pool.shutdown(wait=kind is None, cancel_futures=True)
            self._futures.clear()


# ---------------------------------------------------------------------------------------------
# Heat maps.

# 17 evenly spaced samples of matplotlib's perceptually uniform maps (CC0), interpolated linearly.
_COLORMAPS = {
    "magma": [(0, 0, 4), (10, 8, 34), (29, 17, 71), (54, 16, 107), (81, 18, 124), (106, 28, 129),
              (131, 38, 129), (156, 46, 127), (183, 55, 121), (208, 65, 111), (231, 82, 99),
              (245, 107, 92), (252, 137, 97), (254, 167, 114), (254, 196, 136), (253, 226, 163),
              (252, 253, 191)],
    "viridis": [(68, 1, 84), (72, 24, 106), (71, 45, 123), (66, 64, 134), (59, 82, 139), (51, 99, 141),
                (44, 114, 142), (38, 130, 142), (33, 145, 140), (31, 160, 136), (40, 174, 128),
                (63, 188, 115), (94, 201, 98), (132, 212, 75), (173, 220, 48), (216, 226, 25),
                (253, 231, 37)],
    "gray": [(0, 0, 0), (255, 255, 255)],
    # Signed errors (a bias map): blue below zero, light grey at zero, red above (Moreland's
    # cool-warm end points).
    "coolwarm": [(59, 76, 192), (221, 221, 221), (180, 4, 38)],
}
COLORMAPS = tuple(_COLORMAPS)


# The maps are looked up in a table of this many steps per segment between samples: every
# sample exactly, the rest within 1 of 255 of the linear interpolation (a colour changes by at
# most 31 / 256 a step). A 512² map: 25 ms through np.interp per channel, 3 ms looked up.
COLORMAP_STEPS = 256


@functools.lru_cache(maxsize=None)
def _colormap_table(colormap: str) -> np.ndarray:
    table = np.asarray(_COLORMAPS[colormap], np.float64)
    x = np.linspace(0.0, len(table) - 1, (len(table) - 1) * COLORMAP_STEPS + 1)
    lut = np.stack([np.interp(x, np.arange(len(table)), table[:, k]) for k in range(3)], axis=-1)
    return np.concatenate([np.rint(lut).astype(np.uint8), np.asarray([_NAN_COLOR], np.uint8)])


def apply_colormap(values: np.ndarray, colormap: str = "magma") -> np.ndarray:
    """Values in [0, 1] -> (..., 3) uint8 colours; NaN -> a neutral gray."""
    if colormap not in _COLORMAPS:
        raise SpecError(f"colormap {colormap!r} is not allowed; allowed: {', '.join(COLORMAPS)}")
    lut = _colormap_table(colormap)
    v = np.asarray(values, np.float32)
    steps = len(lut) - 2                       # the last entry is the NaN colour
    index = np.rint(np.clip(v, 0.0, 1.0) * steps)
    index[~np.isfinite(v)] = steps + 1
    return lut[index.astype(np.intp)]


def _tick_text(v: float) -> str:
    return f"{v:.3g}"


@dataclass(frozen=True)
class HeatMap:
    image: np.ndarray       # (H', W', 4) uint8
    x: int                  # where the map's top-left pixel lies in ``image``
    y: int


def heatmap_image(error_map, title: str | None = None, vmin: float = 0.0, vmax: float = 1.0,
                  colormap: str = "magma", ticks: int = 5) -> np.ndarray:
    """An error map as an (H', W', 4) uint8 image: the map, a vertical colour bar on the right
    (vmin at the bottom, vmax at the top) with tick labels, and an optional title above.
    NaN pixels (outside the evaluated region) are drawn gray."""
    return heatmap(error_map, title, vmin, vmax, colormap, ticks).image


def heatmap(error_map, title: str | None = None, vmin: float = 0.0, vmax: float = 1.0,
            colormap: str = "magma", ticks: int = 5, page_srgb=None) -> HeatMap:
    """heatmap_image, and where in it the map's pixels lie (unscaled). ``page_srgb``: a page
    colour (sRGB 0..1) to lay it on, its text set to contrast (default: the charts' dark ground)."""
    from PIL import Image, ImageDraw

    from .layout import BACKGROUND, page_colour, text_colour
    from .text import load_font

    e = np.asarray(error_map, dtype=np.float64)
    if e.ndim == 3 and e.shape[2] == 1:
        e = e[..., 0]
    if e.ndim != 2 or e.size == 0:
        raise SpecError(f"error map must be a non-empty (H, W) array, got shape {e.shape}")
    for name, v in (("vmin", vmin), ("vmax", vmax)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
            raise SpecError(f"{name} must be a finite number, got {v!r}")
    if not vmax > vmin:
        raise SpecError(f"vmax ({vmax:g}) must be greater than vmin ({vmin:g})")
    if not (isinstance(ticks, int) and ticks >= 2):
        raise SpecError(f"ticks must be a whole number >= 2, got {ticks!r}")
    H, W = e.shape
    heat = apply_colormap((e - vmin) / (vmax - vmin), colormap)

    font_size = max(10, round(min(H, 1024) / 40))
    font = load_font(font_size)
    pad = max(6, font_size // 2)
    bar_w = max(10, font_size)
    labels = [_tick_text(vmin + (vmax - vmin) * i / (ticks - 1)) for i in range(ticks)]
    measure = ImageDraw.Draw(Image.new("RGBA", (1, 1)))
    label_w = max(measure.textbbox((0, 0), s, font=font)[2] for s in labels)
    title_h = 0
    if title:
        tb = measure.textbbox((0, 0), title, font=font)
        title_h = tb[3] + pad
    top = pad + title_h + font_size // 2        # room for the top tick label's upper half
    bottom = pad + font_size // 2
    width = pad + W + 2 * pad + bar_w + pad // 2 + 4 + label_w + pad
    if title:
        width = max(width, tb[2] + 2 * pad)
    height = top + H + bottom

    ground = BACKGROUND if page_srgb is None else page_colour(page_srgb)
    line = (200, 200, 200, 255) if page_srgb is None else text_colour("axis", page_srgb)
    canvas = Image.new("RGBA", (width, height), ground)
    canvas.paste(Image.fromarray(heat, "RGB"), (pad, top))
    bar_x = pad + W + 2 * pad
    ramp = apply_colormap(np.linspace(1.0, 0.0, H)[:, None].repeat(bar_w, axis=1), colormap)
    canvas.paste(Image.fromarray(ramp, "RGB"), (bar_x, top))
    draw = ImageDraw.Draw(canvas)
    draw.rectangle((bar_x - 1, top - 1, bar_x + bar_w, top + H), outline=line)
    for i, text in enumerate(labels):
        y = top + (H - 1) * (1.0 - i / (ticks - 1))
        draw.line((bar_x + bar_w, y, bar_x + bar_w + 4, y), fill=line)
        draw.text((bar_x + bar_w + pad // 2 + 4, y), text, font=font, fill=text_colour("label", page_srgb), anchor="lm")
    if title:
        draw.text((pad, pad), title, font=font, fill=text_colour("title", page_srgb))
    return HeatMap(np.asarray(canvas, np.uint8), pad, top)
