"""Faults, injected for real: a missing libEGL (and libOSMesa), a GLSL compile error in a
nested module, an unwritable output directory, a full disk. Each ends in one clear line and
the documented exit status, with no partial file and any pre-existing output intact."""
import os
import shutil
import subprocess
import sys
import textwrap
from contextlib import contextmanager
from pathlib import Path

import pytest

from sdfpbr.shading.compose import shader_dir
from sdfpbr.shading.plan import compose_program as compose
from sdfpbr.errors import ShaderCompileError
from sdfpbr.shading.plan import chart_options
from sdfpbr.spec.chart_spec import make_spec

KEEP = b"pre-existing output, must survive"
NO_EGL = {"GLCONTEXT_LINUX_LIBEGL": "/nonexistent/libEGL.so.1"}        # read by glcontext
NO_OSMESA = {"SDFPBR_LIBOSMESA": "/nonexistent/libOSMesa.so.8"}        # read by sdfpbr.gl


def sdfpbr(*args, env=None, cwd=None):
    return subprocess.run([sys.executable, "-m", "sdfpbr", *map(str, args)], capture_output=True, text=True,
                          env={**os.environ, **(env or {})}, cwd=cwd)


def one_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


def listing(d: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(d.iterdir())}


# ---- no EGL, no OSMesa --------------------------------------------------------------------------

@pytest.mark.requires_backend("osmesa")   # the fallback under test
def test_missing_egl_falls_back_to_osmesa(tmp_path):
    out = tmp_path / "chart.png"
    r = sdfpbr("chart", "--size", "48x48", "--rows", "2", "--cols", "2", "-o", out, env=NO_EGL)
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    doctor = sdfpbr("doctor", env=NO_EGL)
    assert doctor.returncode == 0
    assert "egl     FAIL  EGL backend: /nonexistent/libEGL.so.1 not loaded" in doctor.stdout
    assert "osmesa  ok" in doctor.stdout


def test_missing_egl_with_egl_requested_is_one_line_exit_3(tmp_path):
    out = tmp_path / "chart.png"
    out.write_bytes(KEEP)
    r = sdfpbr("chart", "--backend", "egl", "--size", "32x32", "-o", out, env=NO_EGL)
    line = one_line(r.stderr)
    assert r.returncode == 3 and "EGL backend: /nonexistent/libEGL.so.1 not loaded" in line
    assert out.read_bytes() == KEEP


def test_no_backend_at_all_names_both_and_how_to_install(tmp_path):
    out = tmp_path / "chart.png"
    out.write_bytes(KEEP)
    r = sdfpbr("chart", "--size", "32x32", "-o", out, env={**NO_EGL, **NO_OSMESA})
    line = one_line(r.stderr)
    assert r.returncode == 3
    assert "EGL backend" in line and "OSMesa backend: /nonexistent/libOSMesa.so.8 not found" in line
    assert "apt-get install" in line
    assert listing(tmp_path) == {"chart.png": KEEP}
    doctor = sdfpbr("doctor", env={**NO_EGL, **NO_OSMESA})
    assert doctor.returncode == 3 and "no backend works" in doctor.stdout


# ---- GLSL compile errors ------------------------------------------------------------------------

@pytest.fixture
def broken_shaders(tmp_path):
    """A copy of the shader modules with a syntax error planted in brdf.glsl, which the chart
    program reaches only through a nested #include; returns (root, line)."""
    root = tmp_path / "shaders"
    shutil.copytree(shader_dir(), root)
    brdf = root / "brdf.glsl"
    lines = brdf.read_text().splitlines()
    at = next(i for i, l in enumerate(lines) if l.startswith("vec3 energy_compensation")) + 1
    lines.insert(at, "    float planted = ;")
    brdf.write_text("\n".join(lines) + "\n")
    return root, at + 1


def test_compile_error_names_the_module_and_line(session, broken_shaders):
    root, line = broken_shaders
    source = compose("chart_main.glsl", chart_options(make_spec()), root=root)
    with session.ctx, pytest.raises(ShaderCompileError) as err:
        session.programs.fragment(source)
    assert f"brdf.glsl:{line}" in str(err.value)


def test_compile_error_from_the_cli_is_one_line_exit_4(tmp_path, broken_shaders):
    root, line = broken_shaders
    out = tmp_path / "chart.png"
    out.write_bytes(KEEP)
    r = sdfpbr("chart", "--size", "32x32", "-o", out, env={"SDFPBR_SHADER_DIR": str(root)})
    text = one_line(r.stderr)
    assert r.returncode == 4 and f"GLSL compile error: brdf.glsl:{line}" in text
    assert out.read_bytes() == KEEP


# ---- unwritable and full output locations -------------------------------------------------------

@contextmanager
def mounted_tmpfs(where: Path, options: str):
    where.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)], capture_output=True)
    if r.returncode != 0:
        pytest.skip("cannot mount a tmpfs here (needs root and CAP_SYS_ADMIN)")
    try:
        yield where
    finally:
        subprocess.run(["umount", str(where)], capture_output=True)


@contextmanager
def unwritable_dir(tmp_path: Path):
    """A directory holding a pre-existing output that this process cannot write into: mode
    0555 for a normal user; root ignores modes, so a read-only tmpfs then."""
    if os.geteuid() != 0:
        d = tmp_path / "locked"
        d.mkdir()
        (d / "chart.png").write_bytes(KEEP)
        d.chmod(0o555)
        try:
            yield d
        finally:
            d.chmod(0o755)
        return
    with mounted_tmpfs(tmp_path / "ro", "size=64k") as d:
        (d / "chart.png").write_bytes(KEEP)
        subprocess.run(["mount", "-o", "remount,ro", str(d)], check=True)
        yield d


def test_unwritable_directory_is_refused_before_rendering(tmp_path):
    with unwritable_dir(tmp_path) as d:
        r = sdfpbr("chart", "--size", "32x32", "-o", d / "chart.png")
        assert r.returncode == 2 and "cannot write output" in one_line(r.stderr)
        assert listing(d) == {"chart.png": KEEP}
        # An unwritable side output refuses the whole command: the PNG is not written either.
        png = tmp_path / "fine.png"
        r = sdfpbr("chart", "--size", "32x32", "-o", png, "--hdr", d / "chart.npy")
        assert r.returncode == 2 and "--hdr" in one_line(r.stderr) and not png.exists()


FULL_DISK_SCRIPT = textwrap.dedent("""
    import resource, signal, sys
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)          # write() then fails with EFBIG
    resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))
    from sdfpbr.cli.main import main
    sys.exit(main(sys.argv[1:]))
""")


def test_file_size_limit_is_a_clean_error(tmp_path, cache_dir):
    """RLIMIT_FSIZE: the kernel refuses to grow any file past 4 KiB, as on a full disk."""
    out = tmp_path / "chart.png"
    out.write_bytes(KEEP)
    r = subprocess.run([sys.executable, "-c", FULL_DISK_SCRIPT, "chart", "--size", "96x96", "-o", str(out)],
                       capture_output=True, text=True)
    line = one_line(r.stderr)
    assert r.returncode == 2 and f"cannot write {out}: File too large" in line
    assert listing(tmp_path) == {"chart.png": KEEP}           # no temporary left behind
    # All or nothing: the PNG fits under the limit, the HDR (24 x 24 x 12 bytes) does not, so
    # neither is written and the old PNG keeps its bytes.
    r = subprocess.run([sys.executable, "-c", FULL_DISK_SCRIPT, "chart", "--size", "24x24", "--no-labels",
                        "-o", str(out), "--hdr", str(tmp_path / "chart.npy")], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    assert f"cannot write {tmp_path / 'chart.npy'}: the disk is full" in one_line(r.stderr), r.stderr
    assert listing(tmp_path) == {"chart.png": KEEP}


@pytest.mark.parametrize("suffix", [".gif", ".webp", ".mp4"])
def test_an_animation_over_the_file_size_limit_is_a_clean_error(tmp_path, suffix, cache_dir):
    """Frames stream into the file, so the limit is met mid-animation (or, for MP4, where
    ffmpeg writes its trailer, which imageio-ffmpeg does not check): one line, and the old file
    as it was."""
    if suffix == ".mp4":
        pytest.importorskip("imageio_ffmpeg", reason="the video extra (imageio-ffmpeg) is not installed")
    out = tmp_path / f"orbit{suffix}"
    out.write_bytes(KEEP)
    r = subprocess.run([sys.executable, "-c", FULL_DISK_SCRIPT, "chart", "--size", "96x96", "--frames", "4",
                        "-o", str(out)], capture_output=True, text=True)
    report = "\n".join(line for line in r.stderr.splitlines() if not line.startswith("orbit light: "))   # progress
    assert r.returncode == 2 and f"cannot write {out}" in one_line(report), r.stderr
    assert listing(tmp_path) == {out.name: KEEP}


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
@pytest.mark.parametrize("command", [("bugs",), ("shader",), ("cache", "-v")])
def test_a_full_standard_output_is_one_line(command, cache_dir):
    with open("/dev/full", "w") as full:
        r = subprocess.run([sys.executable, "-m", "sdfpbr", *command], stdout=full, stderr=subprocess.PIPE, text=True)
    assert r.returncode == 2 and "No space left on device" in one_line(r.stderr)


def test_full_disk_is_a_clean_error(tmp_path):
    with mounted_tmpfs(tmp_path / "full", "size=24k") as d:
        (d / "chart.png").write_bytes(KEEP)
        (d / "chart.npy").write_bytes(KEEP)
        r = sdfpbr("chart", "--size", "160x160", "-o", d / "chart.png")
        assert r.returncode == 2 and "No space left on device" in one_line(r.stderr)
        assert listing(d) == {"chart.npy": KEEP, "chart.png": KEEP}
        # The PNG fits, the HDR after it does not: all or nothing, so neither is written.
        r = sdfpbr("chart", "--size", "48x48", "-o", d / "small.png", "--hdr", d / "chart.npy")
        assert r.returncode == 2 and "No space left on device" in one_line(r.stderr)
        assert listing(d) == {"chart.npy": KEEP, "chart.png": KEEP}


# ---- a damaged cache heals --------------------------------------------------------------------

def _entries(cache_dir):
    return sorted(p for kind in ("ibl", "dfg") for p in (cache_dir / kind).glob("*.npz"))


SMALL_CHART = ("chart", "--size", "64x64", "--no-labels")


@pytest.fixture(scope="module")
def clean_bakes(tmp_path_factory):
    """A cache a clean 64 x 64 chart baked into (its IBL, DFG and prepasses; a build of a 64 x 64
    entry reads the same): each test below starts from a copy, damages its entries and
    watches them baked again, without baking them cold first (2.5 of a cold chart's 2.9 CPU
    seconds here)."""
    cache_dir = tmp_path_factory.mktemp("clean") / "cache"
    r = sdfpbr(*SMALL_CHART, "-o", cache_dir.parent / "c.png", env={"SDFPBR_CACHE_DIR": str(cache_dir)})
    assert r.returncode == 0, r.stderr
    return cache_dir


@pytest.mark.parametrize("damage", ["flip a byte", "truncate", "NaN inside"])
def test_a_damaged_cache_entry_is_reported_deleted_and_rebuilt(tmp_path, clean_bakes, damage):
    """Issue 12: one byte flipped in an IBL or DFG entry, a truncated entry, or a well-formed
    one whose floats are NaN: the next chart reports it on one stderr line, renders exactly
    what a clean cache renders, and leaves a good entry in its place."""
    import numpy as np
    from sdfpbr.cache import CHECK, ArrayCache, checksum
    args = SMALL_CHART
    cache_dir = shutil.copytree(clean_bakes, tmp_path / "cache")
    env = {"SDFPBR_CACHE_DIR": str(cache_dir)}
    r = sdfpbr(*args, "-o", tmp_path / "clean.png", "--hdr", tmp_path / "clean.npy", env=env)
    assert r.returncode == 0, r.stderr
    entries = _entries(cache_dir)
    assert entries
    for path in entries:
        data = bytearray(path.read_bytes())
        if damage == "flip a byte":
            data[len(data) // 2] ^= 0xFF
            path.write_bytes(bytes(data))
        elif damage == "truncate":
            path.write_bytes(bytes(data[: len(data) // 3]))
        else:   # well formed, checksum right, values NaN
            with np.load(path) as npz:
                arrays = {k: npz[k] for k in npz.files if k != CHECK}
            name = next(k for k, a in arrays.items() if a.dtype.kind == "f" and a.size > 1)
            arrays[name] = arrays[name].copy()
            arrays[name].flat[0] = np.nan
            key = path.name[: -len(".c.npz")]
            ArrayCache(cache_dir).put(path.parent.name, key, arrays)
            assert np.array_equal(np.load(path)[CHECK], checksum(key, arrays))
    r = sdfpbr(*args, "-o", tmp_path / "again.png", "--hdr", tmp_path / "again.npy", env=env)
    assert r.returncode == 0, r.stderr
    reports = [line for line in r.stderr.splitlines() if "cache entry" in line]
    assert len(reports) == len(entries) and "Traceback" not in r.stderr, r.stderr
    assert np.array_equal(np.load(tmp_path / "clean.npy"), np.load(tmp_path / "again.npy"))
    r = sdfpbr(*args, "-o", tmp_path / "third.png", env=env)   # the rebuilt entries verify
    assert r.returncode == 0 and "cache entry" not in r.stderr, r.stderr


def test_a_damaged_cache_entry_heals_in_a_forced_build(tmp_path, clean_bakes):
    """The same for `build --force`: every IBL and DFG entry damaged, the forced rebuild reports
    each on one line and writes the image the first build wrote."""
    cache_dir = shutil.copytree(clean_bakes, tmp_path / "cache")
    env = {"SDFPBR_CACHE_DIR": str(cache_dir)}
    (tmp_path / "charts").mkdir()
    (tmp_path / "charts" / "small.toml").write_text('size = "64x64"\n')
    r = sdfpbr("build", tmp_path / "charts", "-o", tmp_path / "site", env=env)
    assert r.returncode == 0, r.stderr
    first = (tmp_path / "site" / "small.png").read_bytes()
    entries = _entries(cache_dir)
    assert entries
    for path in entries:
        data = bytearray(path.read_bytes())
        data[len(data) // 2] ^= 0xFF
        path.write_bytes(bytes(data))
    r = sdfpbr("build", tmp_path / "charts", "-o", tmp_path / "site", "--force", env=env)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    assert len([line for line in r.stderr.splitlines() if "cache entry" in line]) == len(entries), r.stderr
    assert (tmp_path / "site" / "small.png").read_bytes() == first


# ---- environments that would render wrong --------------------------------------------------------

def _npy_header_only(path, shape):
    """A .npy whose header claims ``shape`` (float32) with no data behind it."""
    import numpy as np
    with open(path, "wb") as f:
        np.lib.format.write_array_header_1_0(f, {"descr": "<f4", "fortran_order": False, "shape": shape})


def test_an_environment_within_bounds_made_too_bright_by_its_intensity_is_refused(tmp_path):
    """Each within its own bound (values to 1e30, env_intensity to 1e6), their product beyond
    what the bakes sum in float32 (it rendered NaN)."""
    import numpy as np
    env = tmp_path / "env.npy"
    np.save(env, np.full((4, 8, 3), 1e28, np.float32))
    r = sdfpbr("chart", "--size", "32x32", "--env", env, "--env-intensity", "1e6", "-o", tmp_path / "c.png")
    assert r.returncode == 2 and "times env_intensity 1e+06" in one_line(r.stderr), r.stderr
    assert not (tmp_path / "c.png").exists()


@pytest.mark.parametrize("make, message", [
    (lambda np: np.full((4, 8, 3), 3.4e38, np.float32), "over-1e30"),
    (lambda np: np.ones((4, 8, 3)) + 1j, "real numbers"),
    (lambda np: np.full((4, 8, 3), "x"), "real numbers"),
    (lambda np: np.zeros((4, 8), [("r", "f4"), ("g", "f4"), ("b", "f4")]), "real numbers"),
    (None, "cannot read environment"),
])
def test_environments_that_cannot_render_right_are_refused(tmp_path, make, message):
    """Issue 12: values that overflow the bakes, complex, string or structured arrays, and a
    header that claims 200000 x 200000 x 3 texels: one line, exit 2, no output, nothing
    allocated."""
    import numpy as np
    env = tmp_path / "env.npy"
    if make is None:
        _npy_header_only(env, (200000, 200000, 3))
    else:
        np.save(env, make(np))
    r = sdfpbr("chart", "--size", "32x32", "--env", env, "-o", tmp_path / "c.png")
    assert r.returncode == 2 and message in one_line(r.stderr), r.stderr
    assert not (tmp_path / "c.png").exists()


def test_fitting_an_environment_keeps_its_mean_and_order():
    """The area average of a ramp: each output texel the mean of the input it covers (closed
    form), for a length the limit divides and one it does not."""
    import numpy as np
    from sdfpbr.inputs.environment import fit_texture
    ramp = np.arange(12, dtype=np.float32).reshape(1, 12, 1)
    np.testing.assert_allclose(fit_texture(ramp, 4).ravel(), [1, 4, 7, 10])
    # 12 texels into 5: texel i covers [2.4 i, 2.4 (i + 1)); the ramp's texel k is k there.
    expect = [np.mean([k for k in range(12) for _ in range(5)][12 * i:12 * (i + 1)]) for i in range(5)]
    np.testing.assert_allclose(fit_texture(ramp, 5).ravel(), expect, rtol=1e-6)
    assert fit_texture(ramp, 12) is ramp


@pytest.mark.parametrize("rows, extra", [(8, 2), (2, 100000), (4, 100000)])
def test_an_environment_wider_than_gl_allows_is_scaled_to_fit(session, tmp_path, rows, extra):
    """Issue 12: an equirect wider than GL_MAX_TEXTURE_SIZE rendered all black; it is now
    area-averaged down to fit, so a uniform one lights the chart as a uniform one that fits.
    Only the long side shrinks: 2 x 100000 was halved to 0 rows, all black again."""
    import numpy as np
    from sdfpbr.inputs.environment import fit_texture
    limit = int(session.ctx.info["GL_MAX_TEXTURE_SIZE"])
    assert fit_texture(np.ones((rows, limit + extra, 3), np.float32), limit).shape == (rows, limit, 3)
    wide, narrow = tmp_path / "wide.npy", tmp_path / "narrow.npy"
    np.save(wide, np.ones((rows, limit + extra, 3), np.float32))
    np.save(narrow, np.ones((8, 64, 3), np.float32))
    spec = make_spec(width=48, height=48, lights="none", rows=1, cols=2)
    a = session.render(make_spec(spec, env=str(wide))).hdr
    b = session.render(make_spec(spec, env=str(narrow))).hdr
    assert a.min() > 0.01
    np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)


# ---- outputs: all or nothing, never an input -----------------------------------------------------

def test_an_output_that_is_an_input_is_refused(tmp_path):
    import numpy as np
    env = tmp_path / "e.npy"
    np.save(env, np.ones((4, 8, 3), np.float32))
    before = env.read_bytes()
    r = sdfpbr("chart", "--size", "32x32", "--env", env, "--hdr", env, "-o", tmp_path / "c.png")
    assert r.returncode == 2 and "env input" in one_line(r.stderr)
    assert env.read_bytes() == before and not (tmp_path / "c.png").exists()
    tex = tmp_path / "t.png"
    from PIL import Image
    Image.new("RGB", (8, 4), (200, 100, 50)).save(tex)
    before = tex.read_bytes()
    r = sdfpbr("chart", "--size", "32x32", "--base-color-texture", tex, "-o", tex)
    assert r.returncode == 2 and "base_color_texture input" in one_line(r.stderr)
    assert tex.read_bytes() == before


def test_two_outputs_on_one_file_are_refused(tmp_path):
    """Outputs of one command whose names differ but are one file (a link): one line, exit 2,
    before anything is rendered or written."""
    (tmp_path / "h.npy").symlink_to(tmp_path / "a.npz")
    r = sdfpbr("chart", "--size", "32x32", "--hdr", tmp_path / "h.npy", "--aov", tmp_path / "a.npz",
               "-o", tmp_path / "c.png")
    assert r.returncode == 2 and "give each output its own file" in one_line(r.stderr), r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.npy"]


def test_a_chart_killed_while_writing_leaves_its_output_as_it_was(tmp_path):
    """SIGKILL while `chart` writes its PNG (caught by its temporary appearing beside the output):
    the old output keeps its bytes, and the next chart into that file replaces it whole and takes
    the dead writer's temporary away."""
    import signal
    import time
    from sdfpbr.files import TEMP_NAME
    out = tmp_path / "c.png"
    out.write_bytes(KEEP)
    def temporaries():
        return [p for p in tmp_path.iterdir() if TEMP_NAME.match(p.name)]
    writer = subprocess.Popen([sys.executable, "-m", "sdfpbr", "chart", "--size", "3072x3072", "-o", str(out)],
                              cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while not temporaries() and writer.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    writer.send_signal(signal.SIGKILL)
    writer.wait()
    assert writer.returncode == -signal.SIGKILL, "the chart ended before it could be killed while writing"
    assert temporaries() and out.read_bytes() == KEEP
    r = sdfpbr("chart", "--size", "32x32", "-o", out, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert not temporaries() and out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_an_exr_without_openexr_is_refused_before_anything_is_written(tmp_path):
    """Issue 12: without OpenEXR, `chart -o k.png --hdr k.exr` rendered, replaced k.png, then
    failed. Now it fails first and k.png keeps its bytes."""
    blocker = tmp_path / "blocker"
    blocker.mkdir()
    (blocker / "OpenEXR.py").write_text("raise ImportError('blocked for this test')\n")
    out = tmp_path / "k.png"
    out.write_bytes(KEEP)
    env = {"PYTHONPATH": os.pathsep.join([str(blocker), os.environ.get("PYTHONPATH", "")])}
    r = sdfpbr("chart", "--size", "32x32", "-o", out, "--hdr", tmp_path / "k.exr", env=env)
    assert r.returncode == 2 and "OpenEXR" in one_line(r.stderr)
    assert out.read_bytes() == KEEP and not (tmp_path / "k.exr").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp") or ".tmp." in p.name]


# ---- hostile arguments: one line, never a traceback -----------------------------------------------

# Spec files the hostile cases below read (by name in their arguments).
HOSTILE_SPECS = {
    "nested.toml": "roughness = " + "[" * 1000 + "0.5" + "]" * 1000 + "\n",
    "inf-size.toml": "size = [inf, 64]\n",
    "list-size.toml": "size = [[64], 64]\n",
}
# Address-space limits (bytes) some cases run under, whatever memory the machine has.
MEMORY_LIMITS = {"65536x65536": 8 << 30, "20000x20000": 4 << 30}


@pytest.mark.parametrize("args, env, status, message", [
    (("chart", "--spec", "nested.toml"), None, 2, "nested more than"),
    (("build", "nested", "-o", "site"), None, 2, "nested more than"),
    (("chart", "--spec", "inf-size.toml"), None, 2, "size width must be a finite number"),
    (("chart", "--spec", "list-size.toml"), None, 2, "size width must be a number, got [64]"),
    (("stress", "--seed", "-1"), None, 2, "must be in [0, 4294967295]"),
    (("chart", "--frames", "3", "--fps", "0.001", "-o", "s.gif"), None, 2, "fps must be a number in [0.1, 100]"),
    (("chart", "--frames", "3", "--fps", "0.00001", "-o", "s.webp"), None, 2, "fps must be a number in [0.1, 100]"),
    (("chart", "--size", "65536x65536"), None, 2, "GiB of memory"),
    (("chart", "--size", "20000x20000"), None, 2, "GiB of memory"),
    (("chart", "--backend", "osmesa", "--size", "32x32"), {"SDFPBR_LIBOSMESA": "libc.so.6"},
     3, "not an OSMesa library"),
    (("chart", "--device-index", "7", "--size", "32x32"), None, 3, "device index 7, but found"),
    # The real cause: the index, not a missing driver (it said to install Mesa's EGL driver).
    (("chart", "--backend", "egl", "--device-index", "7", "--size", "32x32"), None, 3,
     "(--device-index counts EGL devices from 0)"),
    (("chart", "--size", "2x2048"), None, 2, "fewer pixels than its 5x5 cells"),   # was a GL traceback
    # An output name too long for the temporary written beside it: an OSError traceback.
    (("chart", "--size", "32x32", "-o", "a" * 300 + ".png"), None, 2, "bytes long; at most"),
    # A shader folder without sdfpbr's modules: a ValueError traceback from deep in a compose.
    (("chart", "--size", "32x32"), {"SDFPBR_SHADER_DIR": "/nowhere"}, 2, "holds no sdfpbr shader modules"),
    # Options that would have been ignored, and messages that say what is allowed.
    (("chart", "--lossless", "-o", "s.png"), None, 2, "--lossless applies to animations"),
    (("chart", "--frames", "2", "--lossless", "-o", "s.gif"), None, 2, ".gif has no lossless choice"),
    (("compare", "--bug", "double-gamma", "--lossless"), None, 2, "--lossless applies to animations"),
    (("chart", "--backdrop", "1,1"), None, 2, "R,G,B (sRGB, 0..1)"),
    (("shader", "--display", "--program", "chart-edges"), None, 2, "--display is --program display"),
    (("cache",), {"SDFPBR_CACHE_DIR": "nested.toml"}, 2, "is a file, not a directory"),
    (("chart", "-o", ""), None, 2, "output is empty: give a file name ending in .png"),
])
def test_hostile_arguments_get_one_line(tmp_path, args, env, status, message):
    """Issue 12's tracebacks (RecursionError in chart and build, a size of inf or a list, a
    negative seed, GIF and WebP delays that overflow, 48 GiB and 4 GiB allocations, a library
    that is not OSMesa) and its silent fallbacks (a device index that does not exist, rendered
    on OSMesa or blamed on a missing driver): each is one line with the documented exit status,
    and nothing written."""
    for name, text in HOSTILE_SPECS.items():
        (tmp_path / name).write_text(text)
    (tmp_path / "nested").mkdir()
    (tmp_path / "nested" / "nested.toml").write_text(HOSTILE_SPECS["nested.toml"])
    limit = next((MEMORY_LIMITS[a] for a in args if a in MEMORY_LIMITS), None)
    if limit is not None:
        import resource
        r = subprocess.run([sys.executable, "-m", "sdfpbr", *args], capture_output=True, text=True, cwd=tmp_path,
                           preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, (limit, limit)))
    else:
        r = sdfpbr(*args, env=env, cwd=tmp_path)
    assert r.returncode == status and message in one_line(r.stderr), r.stderr
    if "--device-index" in args:   # the real cause, not a driver to install
        assert "install" not in one_line(r.stderr), r.stderr
    written = [p for p in tmp_path.rglob("*") if p.suffix in (".png", ".gif", ".webp", ".json", ".html")]
    assert not written, written
