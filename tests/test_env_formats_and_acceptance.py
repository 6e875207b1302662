"""No silent acceptance: what a newcomer hands sdfpbr is read as what it is, or refused in one
line (exit 2, nothing written).

* Radiance .hdr (RGBE) environments, the format most HDRIs are published in, are read like
  .exr and .npy ones: equirectangular, row 0 at the zenith, linear float32 radiance. The files
  are made here by a hand-written encoder (Bruce Walter's float2rgbe, run-length encoding
  written out below) from known floats, and the decoded values held to what the format keeps.
* `chart --spec` given a [sweep] or [compare] gallery entry refuses it, naming the commands
  that read it (`sdfpbr build` still does), rather than drawing its [spec] base as a chart.
* `compare A.toml B.toml` refuses two charts whose spheres do not line up (grid, size,
  placement) before rendering, rather than measuring misaligned cells."""
import math
import re
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest

from sdfpbr.errors import SpecError
from sdfpbr.inputs.environment import MAX_ENV_TEXELS, load_env_file
from sdfpbr.spec.chart_spec import load_spec, make_spec


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "sdfpbr", *args], capture_output=True, text=True, cwd=cwd)


def assert_one_line_refusal(r, *words):
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sdfpbr: error: "), r.stderr
    assert "Traceback" not in r.stderr
    for word in words:
        assert word in lines[0], lines[0]


# ---- a hand-written RGBE encoder ------------------------------------------------------------

def rgbe_pixels(rgb: np.ndarray) -> np.ndarray:
    """float (H, W, 3) -> uint8 (H, W, 4) as Walter's float2rgbe writes them: the largest
    channel v = f * 2^e with f in [0.5, 1) (frexp), each channel stored as int(c * f * 256 / v)
    (truncated) and e + 128; below 1e-32 all four bytes 0."""
    out = np.zeros(rgb.shape[:2] + (4,), np.uint8)
    for y, x in np.ndindex(rgb.shape[:2]):
        r, g, b = (float(c) for c in rgb[y, x])
        v = max(r, g, b)
        if v < 1e-32:
            continue
        f, e = math.frexp(v)
        scale = f * 256.0 / v
        out[y, x] = (int(r * scale), int(g * scale), int(b * scale), e + 128)
    return out


def rle_channel(values: bytes) -> bytes:
    """One channel of a scanline as runs: (128 + n, byte) for n <= 127 equal bytes, (n, n bytes)
    for up to 128 others."""
    out, i, n = bytearray(), 0, len(values)
    while i < n:
        j = i
        while j < n and j - i < 127 and values[j] == values[i]:
            j += 1
        if j - i >= 3:
            out += bytes((128 + j - i, values[i]))
            i = j
            continue
        k = i + 1
        while k < n and k - i < 128 and not (k + 2 < n and values[k] == values[k + 1] == values[k + 2]):
            k += 1
        out += bytes((k - i,)) + bytes(values[i:k])
        i = k
    return bytes(out)


def hdr_bytes(scanlines: np.ndarray, *, rle: bool, resolution: str | None = None, header: bytes = b"",
              magic: bytes = b"#?RADIANCE") -> bytes:
    """A .hdr file of ``scanlines`` (N, L, 4) RGBE bytes, in file order."""
    n, length, _ = scanlines.shape
    data = bytearray(magic + b"\n# made by the test\n" + header + b"FORMAT=32-bit_rle_rgbe\n\n")
    data += (resolution or f"-Y {n} +X {length}").encode() + b"\n"
    for line in scanlines:
        if rle:
            data += bytes((2, 2, length >> 8, length & 255))
            for c in range(4):
                data += rle_channel(bytes(line[:, c]))
        else:
            data += line.tobytes()
    return bytes(data)


def write_hdr(path, rgb_or_bytes, **kw):
    pixels = rgb_or_bytes if rgb_or_bytes.dtype == np.uint8 else rgbe_pixels(rgb_or_bytes)
    path.write_bytes(hdr_bytes(pixels, **kw))
    return path


def test_known_values_decode_exactly(tmp_path):
    """Values with 8 significant bits come back whole (the convention: mantissa * 2^(e - 136),
    as stb_image, OpenCV and FreeImage decode); black is 0."""
    rgb = np.array([[[1.0, 1.0, 1.0], [0.5, 0.25, 0.125], [3.0, 1.5, 0.0], [0.0, 0.0, 0.0]],
                    [[1 / 1024, 1 / 2048, 0.0], [200.0, 100.0, 50.0], [65280.0, 1.0, 2.0], [1e-40, 0.0, 0.0]]])
    pixels = rgbe_pixels(rgb)
    assert pixels[0, 0].tolist() == [128, 128, 128, 129]   # 1.0: the example every reader agrees on
    assert pixels[0, 2].tolist() == [192, 96, 0, 130]
    expected = rgb.copy()
    expected[1, 2] = [65280.0, 0.0, 0.0]    # 1 and 2 are below the step 2^8 of 65280's exponent
    expected[1, 3] = 0.0                    # below 1e-32: written black
    for rle in (False, True):
        got = load_env_file(write_hdr(tmp_path / f"k{rle}.hdr", np.tile(pixels, (1, 3, 1)), rle=rle))
        assert got.dtype == np.float32 and got.shape == (2, 12, 3)
        np.testing.assert_array_equal(got, np.tile(expected, (1, 3, 1)).astype(np.float32))


@pytest.mark.parametrize("rle", [False, True], ids=["flat", "rle"])
def test_random_radiance_decodes_within_the_formats_precision(tmp_path, rle):
    """Any radiance comes back within one step of its pixel's shared exponent: with the largest
    channel v = f 2^e (f in [0.5, 1)) the step is 2^(e - 8), at most v 2^-7; the truncating
    writer never rounds up, so decoded <= true < decoded + step. Runs of equal bytes (a flat
    band) and literal stretches (noise) both occur, over a width past 128 (the longest literal)."""
    rng = np.random.default_rng(7)
    rgb = rng.uniform(0.0, 1.0, (6, 300, 3)) * 10.0 ** rng.uniform(-3, 4, (6, 300, 1))
    rgb[:, 40:200] = [0.75, 2.5, 12.0]                    # long runs in every channel
    rgb[2, :, 1] = 0.0
    path = write_hdr(tmp_path / "r.hdr", rgb, rle=rle)
    if rle:
        assert path.stat().st_size < 6 * 300 * 4          # the runs did compress
    got = load_env_file(path).astype(np.float64)
    step = np.array([[math.ldexp(1.0, math.frexp(float(v))[1] - 8) for v in row] for row in rgb.max(axis=-1)])
    assert np.all(got <= rgb) and np.all(rgb - got < step[..., None])
    assert np.all(step <= rgb.max(axis=-1) * 2.0 ** -7)   # the relative precision of 8-bit mantissas


def test_exposure_and_colorcorr_divide(tmp_path):
    """EXPOSURE lines multiply up; the radiance is the pixel over their product (and COLORCORR's
    per channel): the Radiance file format's definition."""
    pixels = rgbe_pixels(np.full((2, 9, 3), 4.0))
    path = write_hdr(tmp_path / "e.hdr", pixels, rle=True,
                     header=b"EXPOSURE=2\nEXPOSURE= 4.0\nCOLORCORR=1 2 0.5\nGAMMA=2.2\nPRIMARIES=0.64 0.33 "
                            b"0.3 0.6 0.15 0.06 0.3127 0.329\n")
    np.testing.assert_array_equal(load_env_file(path)[0, 0], np.float32([0.5, 0.25, 1.0]))


ORIENTATIONS = {   # the resolution line -> the file's scanlines from the image (rows top to bottom)
    "-Y {h} +X {w}": lambda p: p,
    "+Y {h} +X {w}": lambda p: p[::-1],
    "-Y {h} -X {w}": lambda p: p[:, ::-1],
    "+Y {h} -X {w}": lambda p: p[::-1, ::-1],
    "+X {w} -Y {h}": lambda p: p.transpose(1, 0, 2),           # scanlines are columns, left first
    "+X {w} +Y {h}": lambda p: p[::-1].transpose(1, 0, 2),     # ... each from the bottom up
    "-X {w} -Y {h}": lambda p: p[:, ::-1].transpose(1, 0, 2),  # right first
    "-X {w} +Y {h}": lambda p: p[::-1, ::-1].transpose(1, 0, 2),
}


@pytest.mark.parametrize("resolution", ORIENTATIONS)
def test_every_orientation_reads_top_row_first(tmp_path, resolution):
    """resolu.c: -Y runs downward, +X rightward, and the axis named first steps the scanlines."""
    rng = np.random.default_rng(3)
    pixels = rgbe_pixels(rng.uniform(0.1, 8.0, (10, 13, 3)))
    standard = load_env_file(write_hdr(tmp_path / "s.hdr", pixels, rle=False))
    scanlines = np.ascontiguousarray(ORIENTATIONS[resolution](pixels))
    path = write_hdr(tmp_path / "o.hdr", scanlines, rle=True, resolution=resolution.format(h=10, w=13))
    np.testing.assert_array_equal(load_env_file(path), standard)


def test_old_style_runs_repeat_the_pixel_before(tmp_path):
    """Flat scanlines' (1, 1, 1, n) pixels repeat the one before n << s times, s growing by 8 along
    a row of them (Radiance's oldreadcolrs): 43 + (1 << 8) = 299 copies, then 2."""
    a, b = [128, 64, 32, 129], [200, 100, 50, 130]
    row = np.array([a, [1, 1, 1, 43], [1, 1, 1, 1], b, [1, 1, 1, 2], a], np.uint8)
    path = tmp_path / "old.hdr"
    path.write_bytes(b"#?RADIANCE\n\n-Y 2 +X 304\n" + row.tobytes() * 2)
    va, vb = [1.0, 0.5, 0.25], [200 / 64, 100 / 64, 50 / 64]
    expected = np.array([va] * 300 + [vb] * 3 + [va], np.float32)
    np.testing.assert_array_equal(load_env_file(path), np.stack([expected, expected]))


GOOD = hdr_bytes(rgbe_pixels(np.full((4, 16, 3), 2.0)), rle=True)
HEAD, BODY = GOOD.split(b"-Y 4 +X 16\n")
RLE_LINE = bytes((2, 2, 0, 16)) + b"".join(rle_channel(bytes([v] * 16)) for v in (128, 128, 128, 130))


MALFORMED = [
    (b"P6\n16 4\n255\n" + bytes(192), "does not begin with '#?RADIANCE'"),
    (b"ENVI\ndescription = {}\n", "does not begin with '#?RADIANCE'"),
    (GOOD.replace(b"32-bit_rle_rgbe", b"32-bit_rle_xyze"), "CIE XYZ"),
    (GOOD.replace(b"32-bit_rle_rgbe", b"8-bit_rgb"), "is not 32-bit_rle_rgbe"),
    (GOOD.replace(b"FORMAT", b"EXPOSURE=0\nFORMAT"), "EXPOSURE '0' is not a positive number"),
    (GOOD.replace(b"FORMAT", b"EXPOSURE=nan\nFORMAT"), "EXPOSURE 'nan' is not a positive number"),
    (GOOD.replace(b"FORMAT", b"COLORCORR=1 1\nFORMAT"), "COLORCORR '1 1' is not three numbers"),
    (b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n", "no empty line ends its header"),
    (HEAD + b"Y 4 X 16\n" + BODY, "resolution line 'Y 4 X 16'"),
    (HEAD + b"-Y 4 +Y 16\n" + BODY, "names Y twice"),
    (HEAD + b"-Y 0 +X 16\n" + BODY, "empty 16x0 image"),
    (HEAD + b"-Y 20000 +X 20000\n" + BODY, f"is 20000x20000; at most {MAX_ENV_TEXELS} texels"),
    (GOOD[:-5], "the data ends inside scanline 4 of 4"),
    (HEAD + b"-Y 1 +X 16\n" + RLE_LINE[:-1], "the data ends inside scanline 1 of 1"),
    (HEAD + b"-Y 1 +X 16\n" + bytes((2, 2, 0, 17)) + RLE_LINE[4:], "says it holds 17 pixels, not 16"),
    (HEAD + b"-Y 1 +X 16\n" + bytes((2, 2, 0, 16, 128 + 17, 5)) + RLE_LINE[6:], "goes past its 16 pixels"),
    (HEAD + b"-Y 1 +X 16\n" + bytes((2, 2, 0, 16, 0)) + RLE_LINE[4:], "a run of length 0"),
    (HEAD + b"-Y 1 +X 4\n" + bytes((128, 128, 128, 129)) * 3, "the data ends inside scanline 1 of 1"),
    (HEAD + b"-Y 1 +X 4\n" + bytes((128, 128, 128, 129, 1, 1, 1, 9)), "goes past its 4 pixels"),
]


@pytest.mark.parametrize("data, words", MALFORMED, ids=[words for _, words in MALFORMED])
def test_malformed_hdr_files_are_one_line(tmp_path, data, words):
    path = tmp_path / "bad.hdr"
    path.write_bytes(data)
    with pytest.raises(SpecError) as caught:
        load_env_file(path)
    message = str(caught.value)
    assert words in message and "\n" not in message, message


def test_a_huge_declared_image_is_refused_before_allocating(tmp_path):
    """A 40-byte file may declare 16385 x 16385 pixels (1 GiB of bytes, 3 GiB of floats): the
    header is refused before any of it is allocated."""
    path = tmp_path / "huge.hdr"
    path.write_bytes(b"#?RADIANCE\n\n-Y 16385 +X 16385\n" + bytes((2, 2, 64, 1)))
    tracemalloc.start()
    try:
        with pytest.raises(SpecError, match="16385x16385; at most"):
            load_env_file(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 << 20


def test_chart_reads_an_hdr_environment(tmp_path, cache_dir):
    """`chart --env sky.hdr` renders (before: "env 'sky.hdr' is not a preset (did you mean 'sky'?)")."""
    rng = np.random.default_rng(5)
    write_hdr(tmp_path / "sky.hdr", rng.uniform(0.0, 3.0, (16, 32, 3)), rle=True)
    r = run("chart", "--env", "sky.hdr", "--size", "32x32", "--rows", "2", "--cols", "2", "--quality", "draft",
            "-o", "out.png", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "out.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = tmp_path / "bad.hdr"
    bad.write_bytes(b"#?RADIANCE\n\n-Y 2 +X 20\n" + bytes(7))
    r = run("chart", "--env", "bad.hdr", "--size", "32x32", "-o", "bad.png", cwd=tmp_path)
    assert_one_line_refusal(r, "bad.hdr", "Radiance .hdr")
    assert not (tmp_path / "bad.png").exists()


def test_a_uniform_hdr_lights_the_chart_as_ones_do(session, tmp_path):
    """A .hdr of radiance 1 everywhere (128, 128, 128, 129) and an .npy of ones: the same
    environment, the same chart (the radiance read the same, so within 1e-3 relative); and the
    chart `env = "uniform"` draws."""
    ones = np.ones((16, 32, 3), np.float32)
    np.save(tmp_path / "ones.npy", ones)
    write_hdr(tmp_path / "ones.hdr", ones, rle=True)
    np.testing.assert_array_equal(load_env_file(tmp_path / "ones.hdr"), ones)
    base = dict(size="48x48", rows=2, cols=3, quality="draft", lights="none", ground=False)
    via_hdr = session.render(make_spec(env=str(tmp_path / "ones.hdr"), **base)).hdr
    via_npy = session.render(make_spec(env=str(tmp_path / "ones.npy"), **base)).hdr
    assert via_hdr.max() > 0.1
    np.testing.assert_allclose(via_hdr, via_npy, rtol=1e-3, atol=1e-6)
    uniform = session.render(make_spec(env="uniform", **base)).hdr
    np.testing.assert_allclose(via_hdr, uniform, rtol=1e-3, atol=1e-3 * float(uniform.max()))


# ---- gallery entries handed to `chart --spec` -------------------------------------------------

ENTRIES = {
    "sweep": '[sweep]\nfield = "exposure"\nvalues = [-1.0, 1.0]\n[spec]\nsize = "32x32"\nquality = "draft"\n',
    "compare": '[compare]\nbug = "double-gamma"\n[spec]\nsize = "32x32"\nquality = "draft"\n',
}


@pytest.mark.parametrize("kind", ENTRIES)
def test_chart_spec_refuses_a_gallery_entry(tmp_path, kind):
    """Before: the [spec] base drawn as a plain chart, the [sweep]/[compare] table dropped, exit 0."""
    (tmp_path / "x.toml").write_text(ENTRIES[kind])
    with pytest.raises(SpecError, match=rf"x.toml is a \[{kind}\] gallery entry, not a chart spec"):
        load_spec(tmp_path / "x.toml")
    r = run("chart", "--spec", "x.toml", "-o", "x.png", cwd=tmp_path)
    assert_one_line_refusal(r, f"[{kind}] gallery entry", "sdfpbr build", "sdfpbr sweep" if kind == "sweep"
                            else "sdfpbr compare")
    assert not (tmp_path / "x.png").exists()


def test_build_still_reads_the_entries(tmp_path):
    from sdfpbr.features.gallery.entries import collect
    for kind, text in ENTRIES.items():
        (tmp_path / f"{kind}.toml").write_text(text)
    (tmp_path / "plain.toml").write_text('caption = "A chart"\nsize = "32x32"\n')
    items = {item.name: item for item in collect(tmp_path)}
    assert items["sweep"].kind == "sweep" and len(items["sweep"].specs) == 2
    assert items["compare"].kind == "compare" and items["compare"].bug == "double-gamma"
    assert items["plain"].kind == "chart"
    assert load_spec(tmp_path / "plain.toml").width == 32   # a chart entry is still a spec


# ---- compare of charts whose spheres do not line up -------------------------------------------

@pytest.mark.parametrize("b_text, words", [
    ('rows = 5\ncols = 6\nsize = "64x64"\n', "a 5x5 grid of spheres (rows x cols) with a 5x6 one"),
    ('rows = 4\ncols = 5\nsize = "64x64"\n', "a 5x5 grid of spheres (rows x cols) with a 4x5 one"),
    ('rows = 5\ncols = 5\nsize = "64x48"\n', "same size"),
])
def test_compare_refuses_charts_whose_cells_do_not_line_up(tmp_path, b_text, words):
    """Before: a 5x5 and a 5x6 chart measured cell by cell against each other, exit 0."""
    (tmp_path / "a.toml").write_text('rows = 5\ncols = 5\nsize = "64x64"\nquality = "draft"\n')
    (tmp_path / "b.toml").write_text(b_text + 'quality = "draft"\n')
    r = run("compare", "a.toml", "b.toml", "-o", "ab.png", cwd=tmp_path)
    assert_one_line_refusal(r, words)
    assert not (tmp_path / "ab.png").exists()


def test_compare_refuses_spheres_in_other_places():
    """The same grid seen from elsewhere: each sphere's mean would be taken over pixels where
    B shows another part of the chart."""
    from sdfpbr.features.compare import compare_specs
    a = make_spec(rows=3, cols=3, size="96x96", stage="shared", quality="draft")
    with pytest.raises(SpecError, match=r"sphere by sphere: the sphere at row 1, column 1 .*camera_elevation differs"):
        compare_specs(a, make_spec(a, camera_elevation=60.0))


@pytest.mark.parametrize("b_text, words", [
    ('rows = 5\ncols = 6\nsize = "64x64"\n', "a 5x5 grid of spheres (rows x cols) with a 5x6 one"),
    ('[sweep]\nfield = "tonemap"\nvalues = ["aces", "none"]\n', "is a [sweep] gallery entry"),
])
def test_a_builds_compare_pair_is_checked_when_collected(tmp_path, b_text, words):
    """A [compare] entry's a/b files: mismatched grids (measured cell by cell at render time
    before) and an entry that is no spec (its [spec] base was compared) are refused when the
    build collects its entries, before anything renders."""
    from sdfpbr.features.gallery.entries import collect
    charts = tmp_path / "charts"
    charts.mkdir()
    (charts / "a.spec").write_text('rows = 5\ncols = 5\nsize = "64x64"\n')
    (charts / "b.spec").write_text(b_text)
    (charts / "pair.toml").write_text('[compare]\na = "a.spec"\nb = "b.spec"\n')
    with pytest.raises(SpecError, match=re.escape(words)):
        collect(charts)
    r = run("build", str(charts), "-o", str(tmp_path / "out"), cwd=tmp_path)
    assert_one_line_refusal(r, words)
    assert not (tmp_path / "out").exists()
