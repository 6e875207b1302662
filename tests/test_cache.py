"""The on-disk cache: a size cap with least-recently-used eviction, `sdfpbr cache` to list and
clear it, and the temporaries of killed writers cleaned up by the next write."""
import os
import subprocess
import sys
import time

import moderngl
import numpy as np
import pytest

from sdfpbr.cache import ArrayCache, cache_max, enforce_cap
from sdfpbr.errors import SpecError
from sdfpbr.files import write_bytes

from helpers import dead_pid


def entry(cache: ArrayCache, name: str, kib: int, used: float) -> None:
    """An entry of about ``kib`` KiB, last used at ``used`` (seconds since the epoch)."""
    cache.put("ibl", name, {"a": np.zeros(kib * 256, np.float32)})
    os.utime(cache.path("ibl", name), (used, used))   # named by the key's sha256: the cache's own naming


def test_the_cap_evicts_least_recently_used_first(tmp_path, monkeypatch):
    monkeypatch.setenv("SDFPBR_CACHE_MAX", "none")
    cache = ArrayCache(tmp_path)
    now = time.time()
    for i, name in enumerate("abcd"):
        entry(cache, name, 100, now - 100 + i)      # a oldest ... d newest
    assert cache.get("ibl", "a") is not None          # a read marks a used now
    enforce_cap(tmp_path, 250 * 1024)                 # room for two of the four
    left = sorted(p.name for p in (tmp_path / "ibl").iterdir())
    assert left == sorted(cache.path("ibl", name).name for name in "ad")


def test_a_put_keeps_the_cache_under_its_cap(tmp_path, monkeypatch):
    monkeypatch.setenv("SDFPBR_CACHE_MAX", "300K")
    cache = ArrayCache(tmp_path)
    for i in range(6):
        cache.put("ibl", f"k{i}", {"a": np.full(100 * 256, i, np.float32)})
    sizes = [p.stat().st_size for p in (tmp_path / "ibl").iterdir()]
    assert sum(sizes) <= 300 * 1024 and len(sizes) == 2
    assert cache.get("ibl", "k5")["a"][0] == 5       # the newest survive


@pytest.mark.parametrize("text, want", [("2G", 2 << 30), ("500M", 500 << 20), ("1.5k", 1536), ("123", 123),
                                        ("none", None), ("64MiB", 64 << 20)])
def test_cache_max_parses_sizes(monkeypatch, text, want):
    monkeypatch.setenv("SDFPBR_CACHE_MAX", text)
    assert cache_max() == want


@pytest.mark.parametrize("text", ["2X", "-1G", "lots", "", "1e400"])
def test_a_bad_cache_max_is_one_line(monkeypatch, text):
    monkeypatch.setenv("SDFPBR_CACHE_MAX", text)
    with pytest.raises(SpecError, match="SDFPBR_CACHE_MAX"):
        cache_max()


def run(*args, env=None):
    return subprocess.run([sys.executable, "-m", "sdfpbr", *args], capture_output=True, text=True,
                          env={**os.environ, **(env or {})})


def test_cache_command_lists_by_kind_and_clears(tmp_path):
    cache = ArrayCache(tmp_path)
    cache.put("ibl", "x", {"a": np.zeros(1000, np.float32)})
    cache.put("dfg", "y", {"a": np.zeros(10, np.float32)})
    env = {"SDFPBR_CACHE_DIR": str(tmp_path)}
    r = run("cache", env=env)
    assert r.returncode == 0 and "2 entries" in r.stdout
    assert [line.split()[:2] for line in r.stdout.splitlines()[1:]] == [["dfg", "1"], ["ibl", "1"]]
    r = run("cache", "--clear", "--kind", "ibl", env=env)
    assert r.returncode == 0 and "removed 1 entries" in r.stdout
    assert not list((tmp_path / "ibl").iterdir()) and list((tmp_path / "dfg").iterdir())
    r = run("cache", "--kind", "nope", env=env)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "kinds: dfg, ibl" in r.stderr
    r = run("cache", env={**env, "SDFPBR_CACHE_MAX": "2X"})
    assert r.returncode == 2 and "Traceback" not in r.stderr


def test_a_killed_writers_temporaries_go_with_the_next_write(tmp_path):
    """A chart killed while writing leaves `.c.png.<random>.<pid>.tmp.png`; the next write of
    that file removes it, and leaves a live writer's and other files' temporaries alone."""
    pid = dead_pid()
    stale = tmp_path / f".c.png.abc123.{pid}.tmp.png"
    live = tmp_path / f".c.png.def456.{os.getpid()}.tmp.png"
    other = tmp_path / f".d.png.abc123.{pid}.tmp.png"
    for p in (stale, live, other):
        p.write_bytes(b"partial")
    write_bytes(tmp_path / "c.png", b"new")
    assert not stale.exists() and live.exists() and other.exists()
    assert (tmp_path / "c.png").read_bytes() == b"new"


def test_an_exited_writer_not_yet_reaped_is_not_a_live_one(tmp_path):
    """A writer killed with its parent exits as an orphan, a zombie until init reaps it (up to
    ~1 s here): its temporaries are stale at once; a running writer's are not."""
    from sdfpbr.files import remove_stale_temps
    if not os.path.exists("/proc/self/stat"):
        pytest.skip("no /proc: a zombie cannot be told from a live process here")
    exited = subprocess.Popen([sys.executable, "-c", "pass"])
    running = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        for _ in range(200):   # exited, and not waited for: a zombie
            if open(f"/proc/{exited.pid}/stat").read().rsplit(")", 1)[1].split()[0] == "Z":
                break
            time.sleep(0.05)
        gone = tmp_path / f".k.c.npz.abc123.{exited.pid}.tmp"
        live = tmp_path / f".k.c.npz.def456.{running.pid}.tmp"
        for path in (gone, live):
            path.write_bytes(b"partial")
        assert remove_stale_temps(tmp_path) == 1
        assert not gone.exists() and live.exists()
    finally:
        running.kill()
        running.wait()
        exited.wait()


def test_a_killed_bakes_temporaries_go_with_the_next_bake(tmp_path):
    stale = tmp_path / "ibl" / f".k.c.npz.abc123.{dead_pid()}.tmp"
    stale.parent.mkdir()
    stale.write_bytes(b"partial")
    ArrayCache(tmp_path).put("ibl", "other", {"a": np.zeros(4, np.float32)})
    assert not stale.exists()


def test_a_cached_environment_is_uploaded_only_when_read_and_then_the_same(session, cache_dir):
    """From a warm disk cache the cells stage reads the stage probe, not the environment's own
    cube, so that cube is made on first use: a session whose first chart is the cells stage
    (the environment cube left on disk) then renders the shared stage, which reads it, exactly
    as the session that had it uploaded from the start."""
    from sdfpbr.gpu.gl import create_context
    from sdfpbr.gpu.session import Session
    from sdfpbr.spec.chart_spec import make_spec
    cells = make_spec(width=96, height=64, rows=1, cols=2, labels=False)
    shared = make_spec(cells, stage="shared")
    session.render(cells)
    want = session.render(shared).hdr                 # every bake now on disk
    fresh = Session(create_context("egl"), ArrayCache(cache_dir))   # its own context: released below
    try:
        fresh.render(cells)
        np.testing.assert_array_equal(fresh.render(shared).hdr, want)
    finally:
        fresh.release()


READ_LEVELS = """#version 450
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Out { vec4 texel[]; };
uniform samplerCube u_cube;
uniform int u_levels;
void main() {
    // one direction per face, each level read through the mipmapped sampler
    const vec3 faces[6] = vec3[](vec3(1, 0.1, 0.2), vec3(-1, 0.2, 0.1), vec3(0.1, 1, 0.2),
                                 vec3(0.2, -1, 0.1), vec3(0.1, 0.2, 1), vec3(0.2, 0.1, -1));
    for (int f = 0; f < 6; ++f)
        for (int k = 0; k < u_levels; ++k) texel[f * u_levels + k] = textureLod(u_cube, faces[f], float(k));
}
"""
WRITE_LEVEL = """#version 450
layout(local_size_x = 4, local_size_y = 4) in;
layout(rgba32f, binding = 0) uniform writeonly imageCube u_level;
uniform vec4 u_value;
void main() { imageStore(u_level, ivec3(gl_GlobalInvocationID), u_value); }
"""


@pytest.mark.parametrize("backend", ["egl", pytest.param("osmesa", marks=pytest.mark.requires_backend("osmesa"))])
@pytest.mark.parametrize("loader", [True, False], ids=["glTexImage2D", "build_mipmaps"])
def test_a_cube_chain_allocated_without_mipmap_generation_holds_what_each_level_is_given(backend, loader):
    """allocate_cube_levels gives a cube the levels a prefiltered chain is written into without
    glGenerateMipmap (a blit shader's compile on llvmpipe); without a GL loader it falls back to
    build_mipmaps. Either way each level, written by a compute shader as the IBL cache's upload
    writes it, reads back through the mipmapped sampler as exactly what was written, with no GL
    error."""
    from sdfpbr.gpu.gl import allocate_cube_levels, create_context
    ctx = create_context(backend)
    try:
        with ctx:
            if not loader:
                ctx.extra = {**ctx.extra, "gl_function": None}
            size, levels = 16, 4
            cube = ctx.texture_cube((size, size), 4, dtype="f4")
            allocate_cube_levels(ctx, cube, levels)
            write = ctx.compute_shader(WRITE_LEVEL)
            for k in range(levels):
                cube.bind_to_image(0, read=False, write=True, level=k)
                write["u_value"] = (k + 1.0, 10.0 * k, -1.0, 0.5)
                write.run((size >> k) // 4 or 1, (size >> k) // 4 or 1, 6)
                ctx.memory_barrier()
            cube.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
            read = ctx.compute_shader(READ_LEVELS)
            out = ctx.buffer(reserve=6 * levels * 16)
            out.bind_to_storage_buffer(0)
            cube.use(0)
            read["u_cube"], read["u_levels"] = 0, levels
            read.run(1)
            ctx.memory_barrier()
            got = np.frombuffer(out.read(), np.float32).reshape(6, levels, 4)
            assert ctx.error == "GL_NO_ERROR"
        want = np.array([[k + 1.0, 10.0 * k, -1.0, 0.5] for k in range(levels)], np.float32)
        np.testing.assert_array_equal(got, np.broadcast_to(want, got.shape))
    finally:
        ctx.release()


def test_outputs_are_fsynced_and_cache_entries_which_their_readers_verify_are_not(tmp_path, monkeypatch):
    """An output is fsynced before its rename (a power cut leaves the old file or the new one);
    a cache entry is not (a torn one fails its check on read and is made again: the build's
    74 fsyncs were a quarter of a second of its critical path)."""
    from sdfpbr.files import write_group
    from sdfpbr.features.gallery.images import ImageCache
    synced = []
    real = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: (synced.append(fd), real(fd))[1])
    write_bytes(tmp_path / "out.bin", b"output")
    write_group([(tmp_path / "out.txt", lambda tmp: open(tmp, "w").write("output"))])
    assert len(synced) == 2
    ArrayCache(tmp_path / "cache").put("ibl", "k", {"a": np.ones(4, np.float32)})
    assert ImageCache(tmp_path / "cache").put("k" * 64, b"not checked on put")
    assert len(synced) == 2
    assert ArrayCache(tmp_path / "cache").get("ibl", "k")["a"].tolist() == [1, 1, 1, 1]


READ_CUBE_LEVEL = """#version 450
layout(local_size_x = 1) in;
layout(rgba32f, binding = 0) uniform readonly imageCube u_level;
layout(std430, binding = 1) buffer Out { vec4 texel[]; };
uniform int u_size;
void main() {
    for (int f = 0; f < 6; ++f)
        for (int y = 0; y < u_size; ++y)
            for (int x = 0; x < u_size; ++x) texel[(f * u_size + y) * u_size + x] = imageLoad(u_level, ivec3(x, y, f));
}
"""


@pytest.mark.parametrize("backend", ["egl", pytest.param("osmesa", marks=pytest.mark.requires_backend("osmesa"))])
def test_a_chain_is_uploaded_texel_for_texel(backend):
    """upload_cube_levels puts a chain into a cube with glTexImage2D: every texel of every face
    and level reads back (imageLoad, per level) as the array gave it, faces in GL order, row 0
    first, with no GL error; without a GL loader it answers False (the caller copies)."""
    from sdfpbr.gpu.gl import create_context, upload_cube_levels
    rng = np.random.default_rng(7)
    levels = [rng.uniform(-4, 4, (6, 16 >> k, 16 >> k, 4)).astype(np.float32) for k in range(4)]
    ctx = create_context(backend)
    try:
        with ctx:
            cube = ctx.texture_cube((16, 16), 4, dtype="f4")
            assert upload_cube_levels(ctx, cube, levels)
            read = ctx.compute_shader(READ_CUBE_LEVEL)
            for k, want in enumerate(levels):
                out = ctx.buffer(reserve=want.nbytes)
                out.bind_to_storage_buffer(1)
                cube.bind_to_image(0, read=True, write=False, level=k)
                read["u_size"] = want.shape[1]
                read.run(1)
                ctx.memory_barrier()
                np.testing.assert_array_equal(np.frombuffer(out.read(), np.float32).reshape(want.shape), want)
                out.release()
            assert ctx.error == "GL_NO_ERROR"
            ctx.extra = {**ctx.extra, "gl_function": None}
            assert not upload_cube_levels(ctx, cube, levels)
    finally:
        ctx.release()


def test_cached_chains_render_the_same_uploaded_or_copied(session, cache_dir):
    """From a warm cache a session whose context has no GL loader copies the chains into their
    cubes with a compute shader: its charts (the shared stage reads the environment's chain,
    the cells stage its probe's) are those of a session that uploads them."""
    from sdfpbr.gpu.gl import create_context
    from sdfpbr.gpu.session import Session
    from sdfpbr.spec.chart_spec import make_spec
    specs = [make_spec(width=96, height=64, rows=1, cols=2, labels=False, stage=stage) for stage in ("cells", "shared")]
    want = [session.render(spec).hdr for spec in specs]           # every bake now on disk
    for loader in (True, False):
        ctx = create_context("egl")
        if not loader:
            ctx.extra = {**ctx.extra, "gl_function": None}
        fresh = Session(ctx, ArrayCache(cache_dir))
        try:
            for spec, hdr in zip(specs, want):
                np.testing.assert_array_equal(fresh.render(spec).hdr, hdr)
        finally:
            fresh.release()


def test_bakes_are_kept_per_gl_implementation(session, tmp_path, monkeypatch):
    """Drivers round differently: a cache shared by two keeps each one's bakes, and a render
    reads the bakes its own driver made."""
    from sdfpbr.gpu.ibl import IBLBaker
    from sdfpbr.shading.plan import render_plan
    from sdfpbr.spec.chart_spec import make_spec
    plan = render_plan(make_spec())
    cache = ArrayCache(tmp_path)
    def stored():
        return len(list((tmp_path / "dfg").glob("*.npz")))
    with session:
        IBLBaker(session.ctx, session.programs, cache, "driver A").dfg(plan)
        assert stored() == 1
        IBLBaker(session.ctx, session.programs, cache, "driver B").dfg(plan)
        assert stored() == 2
        def no_bake(*args):
            raise AssertionError("driver A's table is in the cache: read, not baked again")
        monkeypatch.setattr(IBLBaker, "compute_dfg_table", no_bake)
        IBLBaker(session.ctx, session.programs, cache, "driver A").dfg(plan)
        assert stored() == 2


def test_reading_only_holds_for_the_calling_thread_and_the_kinds_named(tmp_path):
    """An animation's frames write nothing (or none of some kinds) while another thread's still
    chart keeps writing; the block restores what was before it."""
    import threading
    cache = ArrayCache(tmp_path)
    arrays = {"a": np.zeros(3)}
    with cache.reading_only():
        cache.put("k", "one", arrays)
        other = threading.Thread(target=cache.put, args=("k", "two", arrays))
        other.start()
        other.join()
    assert cache.get("k", "one") is None and cache.get("k", "two") is not None
    with cache.reading_only(("k",)):
        cache.put("k", "three", arrays)
        cache.put("j", "four", arrays)
    assert cache.get("k", "three") is None and cache.get("j", "four") is not None
    cache.put("k", "five", arrays)
    assert cache.get("k", "five") is not None
