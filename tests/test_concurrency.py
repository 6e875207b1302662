"""Builds that are killed, run in parallel processes, or run at the same time on one cache.

Every build here is a real `sdfpbr build` process; kills are real SIGKILLs, either at exact
points (the SDFPBR_BUILD_KILL_AT hook: the build kills itself the n-th time it reaches a
phase) or at arbitrary moments. The check afterwards is always the same: every image in the
output equals the one a clean serial build writes, every cache entry verifies, and no
temporary file is left behind once the next build has run."""
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from sdfpbr.features.gallery.images import KEY_FIELD, png_key

SMALL = 'size = "48x48"\nrows = 2\ncols = 2\n'
ENTRIES = {
    "a.toml": SMALL,
    "b.toml": SMALL + "exposure = 1.0\n",
    "c.toml": SMALL + 'roughness = "0.2:0.6"\n',
    "d.toml": SMALL + "ground = false\n",
    "e.toml": SMALL + 'tonemap = "neutral"\n',
}


def run_build(charts: Path, out: Path, cache: Path, *args: str, wait=True, **env_extra):
    env = {**os.environ, "SDFPBR_CACHE_DIR": str(cache), **env_extra}
    cmd = [sys.executable, "-m", "sdfpbr", "build", str(charts), "-o", str(out), "-q", *args]
    if wait:
        return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    return subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.fixture(scope="module")
def gallery(tmp_path_factory):
    """The chart directory and the images a clean serial build writes from it; that build's
    cache, beside them, keeps its bakes (baked)."""
    root = tmp_path_factory.mktemp("gallery")
    charts = root / "charts"
    charts.mkdir()
    for name, text in ENTRIES.items():
        (charts / name).write_text(text)
    r = run_build(charts, root / "reference", root / "cache", "-j", "1")
    assert r.returncode == 0, r.stderr
    return charts, images(root / "reference")


def baked(gallery, cache: Path) -> Path:
    """``cache`` holding the reference build's bakes (IBL, DFG, prepasses, labels) and none of its
    images: a build there renders and writes every image as into an empty cache, without
    baking again (2.1 of a cold build's 2.7 CPU seconds here). For tests whose claims are about
    the images and the build kind; cold caches stay where bakes are part of the claim."""
    charts, _ = gallery
    shutil.copytree(charts.parent / "cache", cache, ignore=shutil.ignore_patterns("build"))
    return cache


def images(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.glob("*.png"))}


def same_image(a: bytes, b: bytes) -> bool:
    """Same pixels and metadata. The build key is left out of the comparison: it hashes the
    package's Python sources, which may differ between the reference build and a later one
    when the tree is being edited; byte-identity under one key is test_build's business."""
    def content(data):
        with Image.open(io.BytesIO(data)) as im:
            text = {k: v for k, v in im.text.items() if k != KEY_FIELD}
            return np.asarray(im.convert("RGBA")), text
    (pa, ta), (pb, tb) = content(a), content(b)
    return ta == tb and np.array_equal(pa, pb)


def temporaries(*dirs: Path) -> list[Path]:
    return [p for d in dirs if d.exists() for p in d.rglob("*") if p.name.endswith(".tmp")]


def assert_consistent(out: Path, cache: Path, reference: dict[str, bytes], complete: bool) -> None:
    """Every image present is whole and right; every cache entry carries its own key."""
    present = images(out)
    for name, data in present.items():
        assert png_key(data) is not None, f"{name} is not a whole image"
        assert same_image(data, reference[name]), f"{name} differs from the serial build"
    for entry in (cache / "build").glob("*.png"):
        assert png_key(entry.read_bytes()) == entry.stem, f"corrupt cache entry {entry.name}"
    if complete:
        assert sorted(present) == sorted(reference)
        manifest = json.loads((out / "manifest.json").read_text())
        assert sorted(e["image"] for e in manifest["images"]) == sorted(reference)
        assert (out / "index.html").read_text().rstrip().endswith("</html>")
        assert temporaries(out, cache) == []


def test_parallel_build_equals_serial_build(gallery, tmp_path):
    charts, reference = gallery
    r = run_build(charts, tmp_path / "out", tmp_path / "cache", "-j", "2")
    assert r.returncode == 0, r.stderr
    parallel = images(tmp_path / "out")
    assert sorted(parallel) == sorted(reference)
    assert all(same_image(parallel[name], reference[name]) for name in reference)
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["rendered"] == len(reference)


@pytest.mark.parametrize("phase", ["render:2", "cache-temp:1", "cache:3", "output-temp:2", "output:4",
                                   "manifest-temp:1"])
def test_build_killed_at_a_phase_then_rerun_completes(gallery, tmp_path, phase):
    charts, reference = gallery
    out, cache = tmp_path / "out", baked(gallery, tmp_path / "cache")
    killed = run_build(charts, out, cache, SDFPBR_BUILD_KILL_AT=phase)
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    assert_consistent(out, cache, reference, complete=False)
    already = len(list((cache / "build").glob("*.png")))

    r = run_build(charts, out, cache)
    assert r.returncode == 0, r.stderr
    assert_consistent(out, cache, reference, complete=True)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["cached"] == already           # the killed build's finished work is reused


def test_builds_killed_at_arbitrary_moments(gallery, tmp_path):
    charts, reference = gallery
    out, cache = tmp_path / "out", baked(gallery, tmp_path / "cache")
    assert run_build(charts, out, cache).returncode == 0        # warm: the forced builds below only render
    for delay in (0.2, 0.7, 1.2, 1.7, 2.4):
        p = run_build(charts, out, cache, "--force", wait=False)
        time.sleep(delay)
        p.send_signal(signal.SIGKILL)
        p.communicate()
        assert_consistent(out, cache, reference, complete=False)
    r = run_build(charts, out, cache)
    assert r.returncode == 0, r.stderr
    assert_consistent(out, cache, reference, complete=True)


def _processes_with(marker: str) -> list[int]:
    found = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            if marker.encode() in (proc / "environ").read_bytes():
                found.append(int(proc.name))
        except OSError:
            pass
    return found


def test_killed_parallel_build_leaves_no_workers_and_reruns(gallery, tmp_path):
    charts, reference = gallery
    out, cache = tmp_path / "out", baked(gallery, tmp_path / "cache")
    marker = f"SDFPBR_TEST_RUN={uuid.uuid4().hex}"
    name, value = marker.split("=")
    killed = run_build(charts, out, cache, "-j", "2", SDFPBR_BUILD_KILL_AT="output:2", **{name: value})
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    for _ in range(100):                 # orphaned workers notice their parent is gone and exit
        if not _processes_with(marker):
            break
        time.sleep(0.1)
    assert _processes_with(marker) == []
    r = run_build(charts, out, cache, "-j", "2")
    assert r.returncode == 0, r.stderr
    assert_consistent(out, cache, reference, complete=True)


def test_a_dead_writers_temporaries_in_any_cache_kind_go_with_the_next_build(gallery, tmp_path):
    """A worker that exits with its killed build may leave a temporary mid-write in a kind the
    next build does not write to (its bakes all cached): that build removes it all the same,
    and leaves a live writer's alone."""
    from helpers import dead_pid
    charts, reference = gallery
    cache = baked(gallery, tmp_path / "cache")
    assert run_build(charts, tmp_path / "first", cache).returncode == 0      # every bake on disk
    stale = cache / "ibl" / f".k.c.npz.abc123.{dead_pid()}.tmp"
    live = cache / "ibl" / f".k.c.npz.def456.{os.getpid()}.tmp"
    for path in (stale, live):
        path.write_bytes(b"partial")
    r = run_build(charts, tmp_path / "out", cache, "--force")
    assert r.returncode == 0, r.stderr
    assert not stale.exists() and live.exists()
    live.unlink()
    assert_consistent(tmp_path / "out", cache, reference, complete=True)


@pytest.mark.parametrize("force", [False, True], ids=["cold-cache", "both-forced"])
def test_two_builds_sharing_a_cache_at_once(gallery, tmp_path, force):
    """Both builds render (and write) the same keys at the same time into one cache."""
    charts, reference = gallery
    cache = baked(gallery, tmp_path / "cache") if force else tmp_path / "cache"   # cold: both bake at once
    if force:
        assert run_build(charts, tmp_path / "warm", cache).returncode == 0
    extra = ("--force",) if force else ()
    procs = [run_build(charts, tmp_path / f"out{i}", cache, *extra, wait=False) for i in range(2)]
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
    for i in range(2):
        assert_consistent(tmp_path / f"out{i}", cache, reference, complete=True)
    keys = [{e["key"] for e in json.loads((tmp_path / f"out{i}" / "manifest.json").read_text())["images"]}
            for i in range(2)]
    assert keys[0] == keys[1] and keys[0] <= {p.stem for p in (cache / "build").glob("*.png")}


def test_ctrl_c_to_a_parallel_build_is_one_line(gallery, tmp_path):
    """Ctrl-C reaches the whole process group (workers too): the build says it was interrupted,
    exits 130, and no worker prints a traceback."""
    charts, _ = gallery
    env = {**os.environ, "SDFPBR_CACHE_DIR": str(tmp_path / "cache")}
    # A test run started in the background (`pytest &` in a script) inherits SIGINT ignored, and
    # so would the build: give it the default a terminal's foreground job has.
    p = subprocess.Popen([sys.executable, "-m", "sdfpbr", "build", str(charts), "-o", str(tmp_path / "out"),
                          "-j", "2", "--force"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, start_new_session=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    done = 0
    while done < 4:   # "[4/5] x.png  rendered ...": one worker renders the last entry, one waits
        line = p.stderr.readline()
        if not line:
            break
        done += not line.startswith("[...]")   # a slow draw's heartbeat ("still drawing"), no entry
    assert line.startswith("[4/"), line
    os.killpg(p.pid, signal.SIGINT)
    _, rest = p.communicate(timeout=120)
    assert p.returncode == 130, rest
    assert "Traceback" not in rest and rest.strip().endswith("sdfpbr: interrupted")


def test_a_builds_worker_may_start_helpers_and_a_helper_starts_none():
    """One rule for helper processes (workers.helpers): a `-j` build's worker may take them (its
    group of comparisons is the build's longest task), a helper never does (its parent's
    helpers have the cores; a FlipBatch there asks the same rule and measures in-process)."""
    from sdfpbr.workers import HELPERS_FROM, HELPERS_MAX, can_spawn, cores, helper_pool, helpers, process_pool
    if cores() < 2 or not can_spawn():
        pytest.skip("one core, or no worker can start here: no helpers anywhere")
    with process_pool(1) as pool:
        assert pool.submit(helpers, 10).result(timeout=120) == min(cores(), 10, HELPERS_MAX)
    with helper_pool(HELPERS_FROM, ("json",)) as pool:
        assert pool is not None
        assert pool.submit(helpers, 10).result(timeout=120) == 0


def test_helpers_take_the_environment_and_directory_their_pool_is_made_in(tmp_path, monkeypatch):
    """Helpers fork from a server started earlier (by another pool, another test): each pool's
    helpers still see the environment and working directory of its maker at that time."""
    from sdfpbr.workers import HELPERS_FROM, can_spawn, cores, helper_pool
    if cores() < 2 or not can_spawn():
        pytest.skip("one core, or no worker can start here: no helpers")
    for i in range(2):
        where = tmp_path / str(i)
        where.mkdir()
        monkeypatch.chdir(where)
        monkeypatch.setenv("SDFPBR_TEST_HELPER_ENV", str(i))
        if i:
            monkeypatch.delenv("SDFPBR_TEST_HELPER_GONE", raising=False)
        else:
            monkeypatch.setenv("SDFPBR_TEST_HELPER_GONE", "set")
        with helper_pool(HELPERS_FROM, ("json",)) as pool:
            seen = pool.submit(os.getenv, "SDFPBR_TEST_HELPER_ENV").result(timeout=120)
            gone = pool.submit(os.getenv, "SDFPBR_TEST_HELPER_GONE").result(timeout=120)
            cwd = pool.submit(os.getcwd).result(timeout=120)
        assert (seen, gone, cwd) == (str(i), None if i else "set", str(where))


HELD_HELPERS = """
import os, time
from sdfpbr.workers import HELPERS_FROM, helper_pool
if __name__ == "__main__":
    with helper_pool(HELPERS_FROM, ("sdfpbr.features.compare",)) as pool:
        pids = {pool.submit(os.getpid).result(timeout=120) for _ in range(20)}
        print(" ".join(map(str, sorted(pids))), flush=True)
        time.sleep(120)
"""


def test_helpers_and_the_server_they_fork_from_exit_when_their_parent_is_killed(tmp_path):
    """Helpers fork from a server process; killed, the process that started them leaves
    neither behind (the server sees its parent's pipe close, the helpers their parent go)."""
    from sdfpbr.workers import cores
    if cores() < 2:
        pytest.skip("one core: no helpers")
    script = tmp_path / "held.py"
    script.write_text(HELD_HELPERS)
    marker = f"SDFPBR_TEST_RUN={uuid.uuid4().hex}"
    name, value = marker.split("=")
    p = subprocess.Popen([sys.executable, str(script)], env={**os.environ, name: value},
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        helper_pids = {int(pid) for pid in p.stdout.readline().split()}
        assert helper_pids and p.pid not in helper_pids, p.stderr.read() if p.poll() is not None else ""
        assert helper_pids <= set(_processes_with(marker))
    finally:
        p.kill()
        p.wait()
    for _ in range(100):
        if not _processes_with(marker):
            break
        time.sleep(0.1)
    assert _processes_with(marker) == []
