"""The cache owns only its own, and a build deletes only what it wrote.

$SDFPBR_CACHE_DIR may name a folder that holds other files (a thesis, photos, another tool's
`build` folder): the size cap, its eviction and `sdfpbr cache --clear` touch only the entries
sdfpbr wrote (its marker in the root and its naming, sdfpbr.cache), and the cache still works
beside them. `sdfpbr build -o OUT` deletes only images a manifest it wrote lists, each still
the image it wrote; a manifest it did not write deletes nothing. Every manifest is read
bounded (sdfpbr.inputs): a shard's nested 100 000 deep is one line, exit 2."""
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from sdfpbr.cache import MARKER, ArrayCache, cache_entries, enforce_cap, remove_stale_temporaries
from sdfpbr.features.gallery.images import ImageCache

from helpers import dead_pid

HEX = "0123456789abcdef" * 4       # a sha256-shaped name


def plant_foreign(root: Path) -> dict[Path, bytes]:
    """Files sdfpbr did not write, beside and inside its kind folders, older than any entry
    (least recently used: the first an LRU eviction that counted them would take)."""
    files = {
        root / "thesis.pdf": os.urandom(3 << 20),             # past a 2M cap on its own
        root / "photo.jpg": b"\xff\xd8\xff" + os.urandom(5000),
        root / "notes" / "todo.txt": b"buy milk\n",
        root / "photos" / "holiday.png": b"\x89PNG not really",  # a folder named like a kind
        root / "ibl" / "readme.txt": b"mine\n",
        root / "build" / "screenshot.png": b"\x89PNG a screenshot",
        root / "build" / f"{HEX}.txt": b"a hash-named text",
        root / "build" / "stamps" / "diary.json": b"{}",
        root / "build" / f".draft.{dead_pid()}.tmp": b"another tool's temporary",
    }
    old = time.time() - 10 * 86400
    for path, data in files.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        os.utime(path, (old, old))
    return files


def assert_intact(files: dict[Path, bytes]) -> None:
    for path, data in files.items():
        assert path.is_file(), f"{path} was deleted"
        assert path.read_bytes() == data, f"{path} was changed"


def cli(*args, env=None, timeout=120):
    return subprocess.run([sys.executable, "-m", "sdfpbr", *map(str, args)], capture_output=True, text=True,
                          env={**os.environ, **(env or {})}, timeout=timeout)


@pytest.mark.parametrize("cap", ["1", "2M"])
def test_foreign_files_survive_the_cap_and_do_not_count(tmp_path, monkeypatch, cap):
    root = tmp_path / "cache"
    foreign = plant_foreign(root)
    monkeypatch.setenv("SDFPBR_CACHE_DIR", str(root))
    monkeypatch.setenv("SDFPBR_CACHE_MAX", cap)
    arrays, images = ArrayCache(root), ImageCache(root)
    for i in range(24):                                    # 24 x 100 KiB: past a 2M cap
        arrays.put("ibl", f"k{i}", {"a": np.full(100 * 256, i, np.float32)})
        images.put(f"{i:064x}", b"\x89PNG" + os.urandom(1000))
    assert_intact(foreign)
    assert (root / MARKER).is_file()
    own = cache_entries(root)
    assert not set(foreign) & {path for path, _, _ in own}       # never listed as entries
    limit = 1 if cap == "1" else 2 << 20
    assert sum(size for _, size, _ in own) <= limit
    if cap == "2M":    # the foreign 3 MB do not count: the newest entries are kept and read back
        assert arrays.get("ibl", "k23")["a"][0] == 23
        assert len(own) > 10
    enforce_cap(root, 0)                                   # every entry of its own goes, nothing else
    assert cache_entries(root) == [] and arrays.get("ibl", "k23") is None
    assert_intact(foreign)
    monkeypatch.setenv("SDFPBR_CACHE_MAX", "1M")           # room for one: the cache still works
    arrays.put("ibl", "again", {"a": np.ones(4, np.float32)})
    assert arrays.get("ibl", "again")["a"].tolist() == [1, 1, 1, 1]
    assert_intact(foreign)


def test_cache_clear_and_listing_touch_only_sdfpbrs_entries(tmp_path):
    root = tmp_path / "cache"
    foreign = plant_foreign(root)
    cache = ArrayCache(root)
    cache.put("ibl", "x", {"a": np.zeros(1000, np.float32)})
    cache.put("dfg", "y", {"a": np.zeros(10, np.float32)})
    ImageCache(root).put(HEX, b"\x89PNG image")
    (root / "build" / "stamps" / ("ab" * 16 + ".json")).write_text("{}")   # a stamp's name
    env = {"SDFPBR_CACHE_DIR": str(root), "SDFPBR_CACHE_MAX": "1G"}
    r = cli("cache", env=env)
    assert r.returncode == 0 and "4 entries" in r.stdout, r.stdout + r.stderr
    kinds = [line.split()[:2] for line in r.stdout.splitlines()[1:]]
    assert kinds == [["build", "2"], ["dfg", "1"], ["ibl", "1"]]     # no 'notes', no 'photos'
    r = cli("cache", "--kind", "photos", env=env)
    assert r.returncode == 2 and "kinds: build, dfg, ibl" in r.stderr and r.stderr.count("\n") == 1
    r = cli("cache", "--clear", "--kind", "build", env=env)
    assert r.returncode == 0 and "removed 2 entries" in r.stdout
    assert_intact(foreign)
    r = cli("cache", "--clear", env=env)
    assert r.returncode == 0 and "removed 2 entries" in r.stdout
    assert_intact(foreign)
    assert cache_entries(root) == [] and cache.get("ibl", "x") is None
    remove_stale_temporaries(root)                         # another tool's dead temporary stays
    assert_intact(foreign)
    cache.put("ibl", "x", {"a": np.zeros(3, np.float32)})  # the cache works after a clear
    assert cache.get("ibl", "x")["a"].tolist() == [0, 0, 0]


def test_a_folder_sdfpbr_never_wrote_to_loses_nothing_until_it_does(tmp_path):
    """No marker: even a name sdfpbr would give is not removed. The first write marks the
    folder, adopting entries named as sdfpbr names them (an older version's); the rest stays."""
    root = tmp_path / "elsewhere"
    foreign = plant_foreign(root)
    older = root / "ibl" / f"{HEX}.c.npz"
    older.write_bytes(b"an older version's entry")
    env = {"SDFPBR_CACHE_DIR": str(root)}
    r = cli("cache", "--clear", env=env)
    assert r.returncode == 0 and "removed 0 entries" in r.stdout and MARKER in r.stdout
    assert enforce_cap(root, 0) == 0 and older.exists() and not (root / MARKER).exists()
    ArrayCache(root).put("ibl", "new", {"a": np.zeros(4, np.float32)})
    assert (root / MARKER).is_file()
    r = cli("cache", "--clear", env=env)
    assert r.returncode == 0 and "removed 2 entries" in r.stdout
    assert not older.exists()
    assert_intact(foreign)


# ---- the output folder's manifest -------------------------------------------------------------

TINY = 'size = "32x32"\nrows = 1\ncols = 1\nlabels = false\n'


def test_a_manifest_sdfpbr_did_not_write_deletes_nothing(tmp_path, monkeypatch):
    from sdfpbr.features.gallery.build import build
    monkeypatch.setenv("SDFPBR_CACHE_DIR", str(tmp_path / "cache"))
    charts, out = tmp_path / "charts", tmp_path / "out"
    charts.mkdir()
    out.mkdir()
    (charts / "a.toml").write_text(TINY)
    (charts / "b.toml").write_text(TINY + "exposure = 1.0\n")
    mine = {out / "thesis.png": b"\x89PNG my thesis figure", out / "notes.txt": b"notes",
            tmp_path / "outside.png": b"\x89PNG outside"}
    for path, data in mine.items():
        path.write_bytes(data)
    record = {"image": "thesis.png", "name": "thesis", "key": "0" * 64}
    for planted in ({"images": [record]},                                   # no generator
                    {"generator": "sdfpbr", "images": [record]},            # forged: not an image of sdfpbr's
                    {"generator": "sdfpbr", "images": [{**record, "image": "../outside.png", "name": "../outside"}]},
                    "[" * 100_000 + "]" * 100_000):                         # too deep to read
        (out / "manifest.json").write_text(planted if isinstance(planted, str) else json.dumps(planted))
        manifest = build(charts, out)
        assert [e["name"] for e in manifest["images"]] == ["a", "b"]
        assert_intact(mine)
    written = json.loads((out / "manifest.json").read_text())
    assert written["generator"] == "sdfpbr"

    # Its own manifest still takes away the image of an entry that is gone, unless the file
    # under that name is no longer the image it wrote.
    b_png = (out / "b.png").read_bytes()
    (charts / "b.toml").unlink()
    assert [e["name"] for e in build(charts, out)["images"]] == ["a"]
    assert not (out / "b.png").exists()
    (charts / "b.toml").write_text(TINY + "exposure = 1.0\n")
    build(charts, out)
    assert (out / "b.png").read_bytes() == b_png
    (out / "b.png").write_bytes(b"\x89PNG the user's own b.png now")
    (charts / "b.toml").unlink()
    build(charts, out)
    assert (out / "b.png").read_bytes() == b"\x89PNG the user's own b.png now"
    assert_intact(mine)


@pytest.mark.parametrize("kind", ["deep", "fifo", "unhashable name", "escaping name", "foreign"])
def test_a_bad_shard_manifest_is_one_line_exit_2(tmp_path, kind):
    charts, part = tmp_path / "charts", tmp_path / "part"
    charts.mkdir()
    part.mkdir()
    (charts / "a.toml").write_text(TINY)
    manifest = part / "manifest.json"
    record = {"image": "a.png", "name": "a", "key": "0" * 64, "sha256": "0" * 64}
    if kind == "deep":
        manifest.write_text("[" * 100_000 + "]" * 100_000)
    elif kind == "fifo":
        os.mkfifo(manifest)
    elif kind == "unhashable name":
        manifest.write_text(json.dumps({"generator": "sdfpbr", "images": [{**record, "name": [1]}]}))
    elif kind == "escaping name":
        (tmp_path / "secret.png").write_bytes(b"\x89PNG secret")
        manifest.write_text(json.dumps({"generator": "sdfpbr", "images": [{**record, "name": "../secret"}]}))
    else:   # the image is there with the hash named: only the manifest's author is wrong
        import hashlib
        (part / "a.png").write_bytes(b"\x89PNG x")
        sha = hashlib.sha256(b"\x89PNG x").hexdigest()
        manifest.write_text(json.dumps({"images": [{**record, "sha256": sha}], "gl_renderers": []}))
    r = cli("build", charts, "-o", tmp_path / "site", "--merge", part, timeout=60,
            env={"SDFPBR_CACHE_DIR": str(tmp_path / "cache")})
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith("sdfpbr: error: ") and r.stderr.count("\n") == 1, r.stderr
    assert "Traceback" not in r.stderr and str(part) in r.stderr
    assert not (tmp_path / "site").exists()
