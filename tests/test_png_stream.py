"""The streamed PNG encoder: files any decoder reads back to the same pixels, one valid zlib
stream (checksums included) however many blocks and threads encode it, text metadata kept."""
import io
import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from sdfpbr.image import png_stream
from sdfpbr.image.io import png_bytes


def chunks(data: bytes):
    """(kind, body) of each chunk, each chunk's CRC checked."""
    assert data[:8] == png_stream.SIGNATURE
    at = 8
    while at < len(data):
        (length,) = struct.unpack(">I", data[at:at + 4])
        kind, body = data[at + 4:at + 8], data[at + 8:at + 8 + length]
        (crc,) = struct.unpack(">I", data[at + 8 + length:at + 12 + length])
        assert zlib.crc32(kind + body) == crc, kind
        yield kind, body
        at += 12 + length


def unfiltered(raw: bytes, height: int, width: int, channels: int) -> np.ndarray:
    """Undo the up filter of each row (its first byte says which filter: only 2 is written)."""
    rows = np.frombuffer(raw, np.uint8).reshape(height, 1 + width * channels)
    assert (rows[:, 0] == 2).all()
    return np.cumsum(rows[:, 1:], axis=0, dtype=np.uint8).reshape(height, width, channels)


@pytest.mark.parametrize("threads", [1, 3])
@pytest.mark.parametrize("shape,opaque", [((1, 1), True), ((7, 5), False), ((333, 101), True), ((257, 64), False)])
def test_the_pixels_come_back_from_pillow_and_from_zlib(shape, opaque, threads, monkeypatch):
    """Small blocks (a few rows each) so that a stream of many blocks, finished by the last, is
    what both decoders read; zlib.decompress checks the Adler-32 over all of them."""
    monkeypatch.setattr(png_stream, "BLOCK_BYTES", 997)
    rng = np.random.default_rng(shape[0])
    rgba = rng.integers(0, 256, (*shape, 4), dtype=np.uint8)
    rgba[::3, ::2] = 40                                   # runs for deflate to find
    if opaque:
        rgba[..., 3] = 255
    buf = io.BytesIO()
    png_stream.write_png_stream(buf, rgba, {"sdfpbr:spec": "{\"size\": [5, 7]}", "note": "α = r²"}, threads=threads)
    data = buf.getvalue()
    image = Image.open(io.BytesIO(data))
    assert image.mode == ("RGB" if opaque else "RGBA")
    np.testing.assert_array_equal(np.asarray(image.convert("RGBA")), rgba)
    assert image.text == {"sdfpbr:spec": "{\"size\": [5, 7]}", "note": "α = r²"}
    parts = list(chunks(data))
    assert [k for k, _ in parts][0] == b"IHDR" and parts[-1][0] == b"IEND"
    idat = b"".join(body for kind, body in parts if kind == b"IDAT")
    channels = 3 if opaque else 4
    np.testing.assert_array_equal(unfiltered(zlib.decompress(idat), *shape, channels), rgba[..., :channels])


def test_a_strided_view_and_png_bytes_agree_with_the_file_writer(tmp_path):
    """A view into a larger chart (how a render sits in its labelled canvas) encodes as a copy would."""
    rng = np.random.default_rng(3)
    canvas = rng.integers(0, 256, (90, 120, 4), dtype=np.uint8)
    view = canvas[10:70, 20:100]
    from sdfpbr.image.io import png_writer
    png_writer(view, {"k": "v"})(str(tmp_path / "v.png"))
    assert (tmp_path / "v.png").read_bytes() == png_bytes(np.ascontiguousarray(view), {"k": "v"})
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "v.png")), view)


@pytest.mark.parametrize("bad", [np.zeros((4, 4, 3), np.uint8), np.zeros((4, 4, 4), np.float32),
                                 np.zeros((0, 4, 4), np.uint8)])
def test_what_is_not_an_rgba8_image_is_refused(bad):
    with pytest.raises(ValueError):
        png_bytes(bad)
