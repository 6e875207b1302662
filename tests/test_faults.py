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


def test_full_disk_is_a_clean_error(tmp_path):
    with mounted_tmpfs(tmp_path / "full", "size=24k") as d:
        (d / "chart.png").write_bytes(KEEP)
        (d / "chart.npy").write_bytes(KEEP)
        r = sdfpbr("chart", "--size", "160x160", "-o", d / "chart.png")
        assert r.returncode == 2 and "No space left on device" in one_line(r.stderr)
        assert listing(d) == {"chart.npy": KEEP, "chart.png": KEEP}
        # The PNG fits, the HDR after it does not: the PNG is complete, the HDR untouched.
        r = sdfpbr("chart", "--size", "48x48", "-o", d / "small.png", "--hdr", d / "chart.npy")
        assert r.returncode == 2 and "No space left on device" in one_line(r.stderr)
        files = listing(d)
        assert files["chart.npy"] == KEEP and set(files) == {"chart.npy", "chart.png", "small.png"}
        from PIL import Image
        with Image.open(d / "small.png") as im:
            im.load()
