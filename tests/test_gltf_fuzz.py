"""glTF assets, fuzzed (hypothesis): whatever an asset's materials, textures, images, samplers,
buffer views and transforms hold, `sdfpbr chart --gltf` either renders a finite image or says
what is wrong in one line with exit status 2 -- never a traceback, never an output file. Image
bombs (a small file declaring a huge image) are refused before they are decoded."""
import io
import struct
import zlib
from contextlib import redirect_stderr, redirect_stdout

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from sdfpbr.cli.main import main

pygltflib = pytest.importorskip("pygltflib", reason="the gltf extra (pygltflib) is not installed")
from helpers import png_bytes, textured, textured_glb  # noqa: E402

FUZZ = settings(max_examples=150, deadline=None, database=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


def png_header_only(width: int, height: int) -> bytes:
    """A PNG that declares width x height RGBA but holds one compressed row: a decoder that
    trusts the header allocates the whole image before finding out."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
            + chunk(b"IDAT", zlib.compress(b"\0" * (4 * min(width, 64) + 1)))
            + chunk(b"IEND", b""))


SMALL_PNG = png_bytes(np.full((4, 8, 4), 200, np.uint8))

images = st.one_of(
    st.just(SMALL_PNG),
    st.binary(max_size=64),                                            # not an image
    st.integers(8, len(SMALL_PNG) - 1).map(lambda n: SMALL_PNG[:n]),   # truncated
    st.tuples(st.integers(1, 1 << 20), st.integers(1, 1 << 20)).map(lambda wh: png_header_only(*wh)),
    st.just(png_bytes(np.zeros((2, 2), np.uint16))),                   # 16-bit grey
)
numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-5, 5))
# Mostly valid values, so that most assets get past their factors to their textures.
unit = st.one_of(st.none(), st.floats(0, 1), st.floats(0, 1), st.floats(0, 1), numbers)
def unit_list(n):
    return st.one_of(st.none(), st.lists(st.floats(0, 1), min_size=n, max_size=n),
                     st.lists(st.floats(0, 1), min_size=n, max_size=n),
                     st.lists(numbers, max_size=n + 1))
indices = st.one_of(st.just(0), st.just(0), st.just(0), st.none(), st.integers(-2, 3))
transform = st.fixed_dictionaries({}, optional={
    "offset": st.lists(numbers, max_size=3), "rotation": numbers, "scale": st.lists(numbers, max_size=3)})
samplers = st.builds(pygltflib.Sampler, magFilter=st.sampled_from([None, 9728, 9729, 5]),
                     minFilter=st.sampled_from([None, 9728, 9729, 9984, 9987, 9730]),
                     wrapS=st.sampled_from([None, 33071, 33648, 10497, 7]), wrapT=st.sampled_from([None, 10497, -1]))


@st.composite
def assets(draw):
    image = draw(images)
    blob = image + b"\0" * (-len(image) % 4)
    offset = draw(st.one_of(st.just(0), st.just(0), st.integers(-8, len(blob) + 8)))
    length = draw(st.one_of(st.just(len(image)), st.just(len(image)), st.integers(-8, len(blob) + 8)))
    info = {"index": draw(indices), "extensions": {"KHR_texture_transform": draw(transform)}}
    info = pygltflib.TextureInfo(index=info["index"], extensions=info["extensions"] if draw(st.booleans()) else {})
    pbr = pygltflib.PbrMetallicRoughness(
        baseColorFactor=draw(unit_list(4)), metallicFactor=draw(unit), roughnessFactor=draw(unit),
        baseColorTexture=info if draw(st.booleans()) else None,
        metallicRoughnessTexture=info if draw(st.booleans()) else None)
    material = pygltflib.Material(
        name=draw(st.one_of(st.none(), st.text(max_size=8))), pbrMetallicRoughness=pbr,
        alphaMode=draw(st.sampled_from([None, "OPAQUE", "MASK", "BLEND", "mask", ""])),
        alphaCutoff=draw(unit), emissiveFactor=draw(unit_list(3)),
        emissiveTexture=info if draw(st.booleans()) else None,
        normalTexture=pygltflib.NormalMaterialTexture(index=info.index, scale=draw(numbers))
                      if draw(st.booleans()) else None)
    doc = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0"), materials=[material])
    doc.buffers = [pygltflib.Buffer(byteLength=len(blob))]
    doc.bufferViews = [pygltflib.BufferView(buffer=draw(st.sampled_from([0, 0, 0, 1])), byteOffset=offset,
                                            byteLength=length)]
    doc.images = [pygltflib.Image(bufferView=draw(st.sampled_from([0, 0, 0, 2])), mimeType="image/png")]
    doc.samplers = [draw(samplers)]
    doc.textures = [pygltflib.Texture(source=draw(st.sampled_from([0, 0, 0, None, 4])), sampler=draw(indices))]
    doc.set_binary_blob(blob)
    return doc


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("gltf-fuzz")


@FUZZ
@given(doc=assets())
def test_any_gltf_asset_renders_or_is_one_line_exit_2(workdir, cache_dir, doc):
    glb, out, hdr = workdir / "a.glb", workdir / "out.png", workdir / "out.npy"
    out.unlink(missing_ok=True)
    hdr.unlink(missing_ok=True)
    try:
        doc.save_binary(str(glb))
    except (IndexError, ValueError, TypeError):   # pygltflib cannot write it: no asset to read
        assume(False)
    err = io.StringIO()
    with redirect_stderr(err), redirect_stdout(io.StringIO()):
        status = main(["chart", "--gltf", str(glb), "-o", str(out), "--hdr", str(hdr), "--size", "48x48",
                       "--no-labels"])
    if status == 0:   # the radiance behind the image is finite (an 8-bit PNG cannot say)
        assert out.exists() and np.isfinite(np.load(hdr)).all()
    else:
        lines = err.getvalue().strip().splitlines()
        assert status == 2 and len(lines) == 1 and "Traceback" not in lines[0], err.getvalue()
        assert not out.exists() and not hdr.exists()


@pytest.mark.parametrize("width, height", [(30000, 30000), (1 << 20, 2)])
def test_an_image_bomb_is_refused_before_it_is_decoded(tmp_path, width, height):
    """A 100-byte PNG declaring a 3.6-gigabyte image: refused from its header (a decode would
    allocate it first), naming the size and the limit."""
    glb = textured_glb(tmp_path / "bomb.glb", [png_header_only(width, height)], [textured()])
    err = io.StringIO()
    with redirect_stderr(err), redirect_stdout(io.StringIO()):
        status = main(["chart", "--gltf", glb, "-o", str(tmp_path / "x.png"), "--size", "48x48"])
    assert status == 2 and f"{width}x{height}" in err.getvalue() and "at most" in err.getvalue(), err.getvalue()
