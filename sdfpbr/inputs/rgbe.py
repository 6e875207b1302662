"""Radiance ``.hdr`` (RGBE) images read into linear float32: the format most HDR environment
maps are published in. Numpy only: Pillow does not read it, imageio's FreeImage plugin
downloads a binary at run time, and OpenCV is a large dependency for one small format.

The format (Greg Ward, "Real Pixels", Graphics Gems II; Radiance's color.c, header.c and
resolu.c):

* a header of text lines, the first beginning with ``#?`` (``#?RADIANCE``, ``#?RGBE``), ended
  by an empty line. ``FORMAT=32-bit_rle_rgbe`` (the default when absent) is read;
  ``32-bit_rle_xyze`` (CIE XYZ, not RGB) is refused. ``EXPOSURE=`` values say what the pixels
  were multiplied by: the radiance is the pixel divided by the product of them all.
  ``COLORCORR=`` is the same per channel. Other lines (``PRIMARIES=``, ``GAMMA=``, comments,
  commands) do not change the numbers and are not read.
* a resolution line: ``-Y H +X W`` is the standard (scanlines top to bottom, pixels left to
  right); the other seven orientations (``+Y``: bottom to top, ``-X``: right to left, X first:
  each scanline a column) are turned into it here.
* the scanlines, each either run-length encoded per channel (it starts 2, 2, then its length
  in 15 bits: four channels one after another, each as runs: a count over 128 repeats the next
  byte count - 128 times, a count of 1 to 128 is that many bytes as they are), or flat 4-byte
  pixels, where (1, 1, 1, n) repeats the pixel before it n << s times (the old run-length
  encoding; s grows by 8 for each such pixel in a row).

A pixel (r, g, b, e) is r * 2^(e - 136) (and so on) and 0 where e == 0: Bruce Walter's
rgbe.c, as stb_image and OpenCV decode (OpenCV reads the same floats, bit for bit, as this
reader). A value their writers store whole comes back whole: 1.0 is (128, 128, 128, 129),
exactly 1.0, so a uniform file of radiance 1 lights a chart as `env = "uniform"` does.
Radiance's own colr_color() (and libvips, which copies it) adds half a step,
(r + 0.5) * 2^(e - 136): the middle of what its truncating writer maps to r, but 1.0 then
reads as 1.0039. This reader follows the libraries most .hdr files are made and read with,
so a chart lit by a file gets the numbers other tools show. Either way the mantissas are 8
bits with the largest channel's at least 128: one step is at most 2^-7 of that channel."""
from __future__ import annotations

import math
import re

import numpy as np


HEADER_LIMIT = 1 << 20          # the header's text (real ones are a few hundred bytes)
_RESOLUTION = re.compile(rb"([-+])([XY]) +(\d{1,18}) +([-+])([XY]) +(\d{1,18})")
_MIN_RLE, _MAX_RLE = 8, 0x7FFF  # the scanline lengths run-length encoding is used for


class RGBEError(ValueError):
    """What is wrong with a .hdr file's bytes, one line; the caller names the file."""


def _text(raw: bytes, most: int = 60) -> str:
    """Header bytes as text to quote with !r (repr escapes control characters)."""
    words = raw.decode("latin-1")
    return words if len(words) <= most else words[:most] + "..."


def _positive(text: str, what: str, fail) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise fail(f"{what} {_text(text.encode('latin-1'))!r} is not a positive number")
    return value


def read_rgbe(data: bytes, max_texels: int) -> np.ndarray:
    """The Radiance .hdr file ``data`` (its bytes) as float32 radiance (H, W, 3), row 0 at the
    top. An image of more than ``max_texels`` pixels is refused before its pixels are read; a
    malformed or truncated file raises RGBEError, one line saying what is wrong."""
    fail = RGBEError

    if not data.startswith(b"#?"):
        raise fail("it does not begin with '#?RADIANCE' (or another '#?' line)")
    end = data.find(b"\n\n", 0, HEADER_LIMIT)
    if end < 0:
        raise fail(f"no empty line ends its header in the first {HEADER_LIMIT >> 20} MiB")
    exposure, correction = 1.0, [1.0, 1.0, 1.0]
    for line in data[:end].split(b"\n")[1:]:
        key, sep, value = line.partition(b"=")
        if not sep:
            continue
        text = value.decode("latin-1").strip()   # keys as Radiance matches them: at the line's start
        if key == b"FORMAT":
            if text == "32-bit_rle_xyze":
                raise fail("it holds CIE XYZ (FORMAT=32-bit_rle_xyze), not RGB; convert it to RGB "
                           "(32-bit_rle_rgbe) first")
            if text != "32-bit_rle_rgbe":
                raise fail(f"FORMAT {_text(value.strip())!r} is not 32-bit_rle_rgbe")
        elif key == b"EXPOSURE":
            exposure *= _positive(text, "EXPOSURE", fail)
        elif key == b"COLORCORR":
            parts = text.split()
            if len(parts) != 3:
                raise fail(f"COLORCORR {_text(value.strip())!r} is not three numbers")
            correction = [c * _positive(p, "COLORCORR", fail) for c, p in zip(correction, parts)]
    if not all(math.isfinite(v) and v > 0 for v in (exposure, *correction)):
        raise fail("its EXPOSURE or COLORCORR values multiply out beyond a float")
    start = end + 2
    line_end = data.find(b"\n", start, start + 256)
    match = _RESOLUTION.fullmatch(data[start:line_end].strip()) if line_end >= 0 else None
    if match is None:
        shown = _text(data[start:start + 40].split(b"\n")[0])
        raise fail(f"its resolution line {shown!r} is not like '-Y 512 +X 1024'")
    (major_sign, major, n_scan), (minor_sign, minor, length) = \
        ((match[1], match[2], int(match[3])), (match[4], match[5], int(match[6])))
    if major == minor:
        raise fail(f"its resolution line {_text(match[0])!r} names {major.decode()} twice")
    height, width = (n_scan, length) if major == b"Y" else (length, n_scan)
    if height < 1 or width < 1:
        raise fail(f"it declares an empty {width}x{height} image")
    if width * height > max_texels:   # before anything is allocated: a small file may declare much
        raise fail(f"it is {width}x{height}; at most {max_texels} texels are read: scale it down")
    pixels = np.empty((n_scan, length, 4), np.uint8)
    pos = line_end + 1
    for i in range(n_scan):
        if (_MIN_RLE <= length <= _MAX_RLE and pos + 4 <= len(data) and data[pos] == 2 and data[pos + 1] == 2
                and data[pos + 2] < 128):
            declared = data[pos + 2] << 8 | data[pos + 3]
            if declared != length:
                raise fail(f"scanline {i + 1} of {n_scan} says it holds {declared} pixels, not {length}")
            channels, pos = _rle_scanline(data, pos + 4, length, i, n_scan, fail)
            pixels[i] = np.frombuffer(channels, np.uint8).reshape(4, length).T
        else:
            pixels[i], pos = _flat_scanline(data, pos, length, i, n_scan, fail)
    # To rows top to bottom, pixels left to right (resolu.c: -Y is downward, +X rightward).
    if major == b"X":
        pixels = pixels.transpose(1, 0, 2)          # each scanline was a column
    x_sign, y_sign = (minor_sign, major_sign) if major == b"Y" else (major_sign, minor_sign)
    if y_sign == b"+":
        pixels = pixels[::-1]
    if x_sign == b"-":
        pixels = pixels[:, ::-1]
    return _radiance(pixels, exposure, correction)


def _radiance(pixels: np.ndarray, exposure: float, correction: list[float]) -> np.ndarray:
    """(H, W, 4) RGBE bytes as float32 (H, W, 3): mantissa * 2^(e - 136) (0 for e == 0; the
    convention: module docstring) over the product of the EXPOSURE and COLORCORR values. With
    none (or powers of two) every value is exact in float32: an 8-bit mantissa times a power of
    two from 2^-135 (a float32 subnormal, still exact) to 2^119."""
    step = np.ldexp(1.0, np.arange(256) - 136)
    step[0] = 0.0
    out = np.empty(pixels.shape[:2] + (3,), np.float32)
    for c in range(3):
        table = (step / (exposure * correction[c])).astype(np.float32)
        np.multiply(pixels[..., c], table[pixels[..., 3]], out=out[..., c])
    return out


def _rle_scanline(data: bytes, pos: int, length: int, row: int, rows: int, fail) -> tuple[bytearray, int]:
    """A run-length encoded scanline's four channels, one after the other, and where it ends."""
    out = bytearray(4 * length)
    size = len(data)
    for c in range(4):
        x, stop = c * length, (c + 1) * length
        while x < stop:
            if pos >= size:
                raise fail(f"the data ends inside scanline {row + 1} of {rows}")
            count = data[pos]
            if count > 128:
                n = count - 128
                if pos + 1 >= size:
                    raise fail(f"the data ends inside scanline {row + 1} of {rows}")
                chunk = data[pos + 1:pos + 2] * n
                pos += 2
            else:
                n = count
                if n == 0:
                    raise fail(f"scanline {row + 1} of {rows} holds a run of length 0")
                if pos + 1 + n > size:
                    raise fail(f"the data ends inside scanline {row + 1} of {rows}")
                chunk = data[pos + 1:pos + 1 + n]
                pos += 1 + n
            if x + n > stop:
                raise fail(f"a run in scanline {row + 1} of {rows} goes past its {length} pixels")
            out[x:x + n] = chunk
            x += n
    return out, pos


def _flat_scanline(data: bytes, pos: int, length: int, row: int, rows: int, fail) -> tuple[np.ndarray, int]:
    """A scanline of 4-byte pixels, (1, 1, 1, n) repeating the one before (the old run-length
    encoding: Radiance's oldreadcolrs), as (length, 4) bytes, and where it ends."""
    available = (len(data) - pos) // 4
    take = min(available, length)
    truncated = fail(f"the data ends inside scanline {row + 1} of {rows}")
    while True:
        if take < 1:
            raise truncated
        records = np.frombuffer(data, np.uint8, count=4 * take, offset=pos).reshape(take, 4)
        repeat = (records[:, 0] == 1) & (records[:, 1] == 1) & (records[:, 2] == 1)
        repeat[0] = False   # a scanline's first pixel is a pixel (readcolrs reads it before any run)
        if not repeat.any():
            if take < length:
                raise truncated
            return records, pos + 4 * length
        index = np.arange(take)
        last_pixel = np.maximum.accumulate(np.where(repeat, -1, index))
        shift = np.where(repeat, 8 * (index - last_pixel - 1), 0)   # 0, 8, 16, ... along a row of repeats
        counts = np.where(repeat, records[:, 3].astype(np.int64) << np.minimum(shift, 40), 1)
        total = np.cumsum(np.minimum(counts, length + 1))
        done = int(np.searchsorted(total, length))   # the record that fills the scanline
        if done == take:
            if take >= available:
                raise truncated
            take = min(available, 2 * take)   # repeats of 0 pixels took records: read on
            continue
        if total[done] != length:
            raise fail(f"a run in scanline {row + 1} of {rows} goes past its {length} pixels")
        source = np.where(repeat, last_pixel, index)[:done + 1]
        return np.repeat(records[source], counts[:done + 1], axis=0), pos + 4 * (done + 1)
