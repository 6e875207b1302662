"""Animations written one frame at a time, so memory stays flat in the frame count.

Pillow's multi-frame GIF and WebP writers hold every frame until the end (a 3600-frame chart
GIF grew past 13 GB), so each frame is encoded on its own by Pillow (a one-frame GIF or a
lossless WebP) and its image data is appended to the open file inside the animation
container: GIF89a blocks with a local colour table per frame, or WebP ANMF chunks in a RIFF
whose sizes are patched at the end. MP4 streams through imageio-ffmpeg. The file is written
under a temporary name and renamed into place only when the last frame is in (sdfpbr.files).
"""
from __future__ import annotations

import io
import os
import struct
from pathlib import Path

import numpy as np
from PIL import Image

from ..files import atomic_path
from ..spec.presets import WEBP_METHOD, WEBP_QUALITY
from .sheet import flatten

GIF_MIN_DELAY_MS = 20   # viewers slow delays under 20 ms down to 100 ms


# Lossless WebP frames (on request; lossy: spec.presets.WEBP_QUALITY): exact, ~250 kB in ~50 ms
# for the default chart at method 0 / effort 50.
WEBP_LOSSLESS_EFFORT = 50


class AnimationWriter:
    """``with AnimationWriter(path, fps, suffix) as w: w.add(frame)`` for (H, W, 4) uint8 frames
    of one size; the suffix (.gif, .webp, .mp4) picks the container, ``lossless`` the WebP mode."""

    def __init__(self, path: str | Path, fps: float, suffix: str, lossless: bool = False):
        self.path, self.fps, self.suffix, self.lossless = Path(path), float(fps), suffix, lossless
        self.frames = 0
        self.size: tuple[int, int] | None = None

    def __enter__(self) -> "AnimationWriter":
        self._atomic = atomic_path(self.path, self.suffix)
        self._tmp = self._atomic.__enter__()
        try:
            self._file = open(self._tmp, "wb") if self.suffix != ".mp4" else None
            self._mp4 = None
        except BaseException as exc:
            self._atomic.__exit__(type(exc), exc, exc.__traceback__)
            raise
        return self

    def add(self, frame: np.ndarray) -> None:
        frame = np.asarray(frame, np.uint8)
        if frame.ndim != 3 or frame.shape[2] != 4:
            raise ValueError(f"expected an (H, W, 4) uint8 frame, got {frame.shape}")
        size = (frame.shape[1], frame.shape[0])
        if self.size is None:
            self.size = size
        elif size != self.size:
            raise ValueError(f"animation frames differ in size: {self.size} then {size}")
        {".gif": self._add_gif, ".webp": self._add_webp, ".mp4": self._add_mp4}[self.suffix](frame)
        self.frames += 1

    def __exit__(self, kind, exc, tb) -> bool:
        try:
            if kind is None:
                if self.frames == 0:
                    raise ValueError("an animation needs at least one frame")
                self._finish()
        except BaseException as error:
            kind, exc, tb = type(error), error, error.__traceback__
            self._close_quietly()
            self._atomic.__exit__(kind, exc, tb)
            raise
        if kind is not None:
            self._close_quietly()
        return bool(self._atomic.__exit__(kind, exc, tb))   # renames into place on success

    def _close_quietly(self) -> None:
        """Close after a failure, which is what gets reported: closing flushes what is
        buffered, and on a full disk that fails again."""
        if self._file is not None and not self._file.closed:
            try:
                self._file.close()
            except OSError:
                pass
        if self._mp4 is not None:
            try:
                self._mp4.close()
            except Exception:
                pass
            self._mp4 = None

    def _finish(self) -> None:
        if self.suffix == ".gif":
            self._file.write(b"\x3b")                                   # trailer
        elif self.suffix == ".webp":
            end = self._file.tell()
            self._file.seek(4)
            self._file.write(struct.pack("<I", end - 8))                # RIFF size
            self._file.seek(20)                                          # VP8X flags
            self._file.write(bytes([0x02 | (0x10 if self._alpha else 0)]))
        elif self._mp4 is not None:
            try:
                self._mp4.close()
            except OSError:
                raise self._ffmpeg_failed() from None
            self._mp4 = None
            # imageio-ffmpeg does not read ffmpeg's exit status: a trailer it could not write
            # (the disk full at the end) left a truncated file that would be renamed into place.
            if not _mp4_complete(self._tmp):
                raise self._ffmpeg_failed()
        if self._file is not None:
            self._file.close()

    # ---- GIF -----------------------------------------------------------------------------
    def _add_gif(self, frame: np.ndarray) -> None:
        rgb = Image.fromarray(np.ascontiguousarray(_opaque(frame)[..., :3]), "RGB")
        # A median-cut palette per frame, then Floyd–Steinberg error diffusion onto it (Pillow
        # dithers only onto a given palette): smooth metals show no colour-band rings.
        palette = rgb.quantize(256, method=Image.Quantize.MEDIANCUT)
        indexed = rgb.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG)
        buf = io.BytesIO()
        indexed.save(buf, format="GIF", interlace=False)   # the descriptor written below is not interlaced
        table, image = _gif_frame(buf.getvalue())
        w, h = self.size
        if self.frames == 0:
            # Header, a screen without a global table, and the loop-forever extension.
            self._file.write(b"GIF89a" + struct.pack("<HHBBB", w, h, 0x70, 0, 0))
            self._file.write(b"\x21\xff\x0bNETSCAPE2.0\x03\x01\x00\x00\x00")
        delay_cs = max(GIF_MIN_DELAY_MS, 10 * round(1000.0 / self.fps / 10)) // 10
        self._file.write(struct.pack("<BBBBHBB", 0x21, 0xF9, 4, 0x04, delay_cs, 0, 0))   # keep the frame
        bits = max(1, (len(table) // 3 - 1).bit_length()) - 1           # table size = 2^(bits+1)
        table = table + bytes(3 * (2 ** (bits + 1)) - len(table))
        self._file.write(struct.pack("<BHHHHB", 0x2C, 0, 0, w, h, 0x80 | bits) + table + image)

    # ---- WebP ----------------------------------------------------------------------------
    def _add_webp(self, frame: np.ndarray) -> None:
        alpha = bool((frame[..., 3] < 255).any())
        image = Image.fromarray(np.ascontiguousarray(frame if alpha else frame[..., :3]), "RGBA" if alpha else "RGB")
        buf = io.BytesIO()
        if self.lossless:   # exact: colour under alpha 0 kept
            image.save(buf, format="WEBP", lossless=True, exact=True, method=0, quality=WEBP_LOSSLESS_EFFORT)
        else:
            image.save(buf, format="WEBP", quality=WEBP_QUALITY, method=WEBP_METHOD, alpha_quality=100)
        data = b"".join(_riff_chunk(kind, body) for kind, body in _webp_chunks(buf.getvalue())
                        if kind in (b"ALPH", b"VP8 ", b"VP8L"))
        w, h = self.size
        if self.frames == 0:
            self._alpha = False
            self._file.write(b"RIFF\0\0\0\0WEBP")
            self._file.write(_riff_chunk(b"VP8X", bytes(4) + _u24(w - 1) + _u24(h - 1)))
            self._file.write(_riff_chunk(b"ANIM", bytes(4) + struct.pack("<H", 0)))   # loop forever
        self._alpha |= alpha
        duration = round(1000.0 / self.fps)
        header = _u24(0) + _u24(0) + _u24(w - 1) + _u24(h - 1) + _u24(duration) + bytes([0x02])   # no blending
        self._file.write(_riff_chunk(b"ANMF", header + data))

    # ---- MP4 -----------------------------------------------------------------------------
    def _add_mp4(self, frame: np.ndarray) -> None:
        rgb = _opaque(frame)[..., :3]
        # H.264 in yuv420p needs even sizes: pad by a row / column of the edge, never scale.
        h, w = rgb.shape[:2]
        rgb = np.ascontiguousarray(np.pad(rgb, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge"))
        if self._mp4 is None:
            import imageio_ffmpeg
            # ffmpeg quiet: a failure is reported in one line (_ffmpeg_failed), not its log
            self._mp4 = imageio_ffmpeg.write_frames(
                self._tmp, (rgb.shape[1], rgb.shape[0]), fps=self.fps, codec="libx264", pix_fmt_in="rgb24",
                pix_fmt_out="yuv420p", macro_block_size=1, output_params=["-movflags", "+faststart"],
                ffmpeg_log_level="quiet")
            self._mp4.send(None)
        try:
            self._mp4.send(rgb.tobytes())
        except OSError:
            raise self._ffmpeg_failed() from None

    def _ffmpeg_failed(self) -> OSError:
        """What stopped ffmpeg, as far as can be told from here: a full disk or its own error."""
        import errno
        import shutil
        if shutil.disk_usage(Path(self._tmp).parent).free < (1 << 20):
            return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return OSError(errno.EIO, "ffmpeg stopped writing it")


def _opaque(frame: np.ndarray) -> np.ndarray:
    """The frame over the chart background where it is transparent (formats without alpha)."""
    return frame if frame[..., 3].min() == 255 else flatten(frame)


def _u24(value: int) -> bytes:
    return value.to_bytes(3, "little")


def _mp4_complete(path: str | Path) -> bool:
    """Whether the MP4 at ``path`` is whole: its top-level boxes tile the file exactly, and a
    movie header (moov) and the media data (mdat) are among them."""
    with open(path, "rb") as f:
        length = os.fstat(f.fileno()).st_size
        at, kinds = 0, set()
        while at < length:
            f.seek(at)
            head = f.read(16)
            if len(head) < 8:
                return False
            size, kind = struct.unpack(">I4s", head[:8])
            if size == 1 and len(head) == 16:
                size = struct.unpack(">Q", head[8:])[0]
            elif size == 0:   # the last box runs to the end of the file
                size = length - at
            if size < 8:
                return False
            kinds.add(kind)
            at += size
    return at == length and {b"moov", b"mdat"} <= kinds


def _riff_chunk(kind: bytes, body: bytes) -> bytes:
    return kind + struct.pack("<I", len(body)) + body + (b"\0" if len(body) % 2 else b"")


def _webp_chunks(data: bytes):
    """(fourcc, body) of each chunk of a WebP file."""
    pos = 12
    while pos + 8 <= len(data):
        kind, size = data[pos:pos + 4], struct.unpack("<I", data[pos + 4:pos + 8])[0]
        yield kind, data[pos + 8:pos + 8 + size]
        pos += 8 + size + (size % 2)


def _gif_frame(data: bytes) -> tuple[bytes, bytes]:
    """(colour table, image data from the LZW code size to the block terminator) of the first
    image of a GIF file."""
    packed = data[10]
    pos = 13
    table = b""
    if packed & 0x80:
        n = 3 * 2 ** ((packed & 7) + 1)
        table, pos = data[pos:pos + n], pos + n
    while data[pos] == 0x21:                       # extensions: skip their sub-blocks
        pos += 2
        while data[pos]:
            pos += data[pos] + 1
        pos += 1
    if data[pos] != 0x2C:
        raise ValueError("the one-frame GIF holds no image descriptor")
    local = data[pos + 9]
    pos += 10
    if local & 0x80:
        n = 3 * 2 ** ((local & 7) + 1)
        table, pos = data[pos:pos + n], pos + n
    start = pos
    pos += 1                                       # LZW minimum code size
    while data[pos]:
        pos += data[pos] + 1
    return table, data[start:pos + 1]
