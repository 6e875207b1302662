"""A seeded fuzz over the classes of hostile input (RELIABILITY.md, "Hostile inputs"): paths
that lead out of their folder, special files, sizes, nesting, and cache folders holding
other files (interrupts: tests/test_interrupts.py, seeded the same way).
Each case's expected outcome is derived without the code under test
(os.path.realpath for confinement, the shape arithmetic for sizes, the depth that was
written for nesting); every refusal must be a SpecError, never another exception or a hang.

SDFPBR_FUZZ_SEED picks the cases (default 0, what CI runs); SDFPBR_FUZZ_CASES scales how many
(default 1: about 20 s here). A failure names its seed and case, so it can be run again."""
from __future__ import annotations

import os
import random
import signal
import socket
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from sdfpbr.errors import SpecError

SEED = int(os.environ.get("SDFPBR_FUZZ_SEED", "0"))
SCALE = max(1, int(os.environ.get("SDFPBR_FUZZ_CASES", "1")))
HANG_SECONDS = 20   # a read that blocks this long is a hang (a FIFO waiting for a writer)


def rng(name: str) -> random.Random:
    return random.Random(f"{SEED}:{name}")


@contextmanager
def no_hang(what: str):
    """Fail, instead of stalling the suite, when the block blocks (an open() of a FIFO)."""
    def alarm(signum, frame):
        raise AssertionError(f"{what}: still blocked after {HANG_SECONDS} s (seed {SEED})")
    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(HANG_SECONDS)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def one_line(exc: BaseException) -> str:
    text = str(exc)
    assert text and "\n" not in text and "Traceback" not in text, repr(text)
    return text


# ---- special files: every reader refuses what is not a regular file within its limit -------------

def special_files(tmp: Path) -> dict[str, Path]:
    """A FIFO, a character device, a socket, a directory, a symlink to a device, and a sparse
    file past every size limit (it takes no disk), each named with the suffix readers want."""
    made = {}
    fifo = tmp / "fifo"
    os.mkfifo(fifo)
    made["fifo"] = fifo
    made["device"] = Path("/dev/zero")
    made["directory"] = tmp / "folder.d"
    made["directory"].mkdir()
    sock = socket.socket(socket.AF_UNIX)
    sock.bind(str(tmp / "sock"))
    made["socket"] = tmp / "sock"
    (tmp / "to-device").symlink_to("/dev/zero")
    made["symlink to a device"] = tmp / "to-device"
    huge = tmp / "huge"
    with open(huge, "wb") as f:
        f.truncate(5 << 30)
    made["oversized"] = huge
    return made


def readers():
    """(name, suffix, read(path)) for each reader of a file an input names."""
    from sdfpbr.inputs.environment import load_env_file
    from sdfpbr.inputs import read_json
    from sdfpbr.spec.chart_spec import load_spec, make_spec
    from sdfpbr.devtools.baseline import load_shadertoy
    return [
        ("spec", ".toml", lambda p: load_spec(p)),
        ("environment (.npy)", ".npy", lambda p: load_env_file(p)),
        ("environment (spec field)", ".npy", lambda p: make_spec(env=str(p))),
        ("texture (spec field)", ".png", lambda p: make_spec(base_color_texture=str(p))),
        ("gltf (spec field)", ".glb", lambda p: make_spec(gltf=str(p))),
        ("manifest", ".json", lambda p: read_json(p, "manifest")),
        ("bench baseline", ".glsl", lambda p: load_shadertoy(p)),
    ]


def test_special_files_are_refused_by_every_reader(tmp_path):
    specials = special_files(tmp_path)
    r = rng("special")
    cases = [(name, kind) for name, _, _ in readers() for kind in specials]
    r.shuffle(cases)
    by_name = {name: (suffix, read) for name, suffix, read in readers()}
    for name, kind in cases:
        suffix, read = by_name[name]
        link = tmp_path / f"{name.split()[0]}-{kind.replace(' ', '-')}{suffix}"   # the suffix the reader wants
        if not link.exists():
            link.symlink_to(specials[kind])
        with no_hang(f"{name} of a {kind}"), pytest.raises(SpecError) as caught:
            read(link)
        one_line(caught.value)


def test_special_files_are_never_replaced_as_outputs(tmp_path):
    """An output name that is a FIFO, socket or device (or a link to one) is refused before
    rendering: the atomic rename would have put a regular file in its place."""
    from sdfpbr.errors import OutputError
    from sdfpbr.image.io import check_writable
    specials = special_files(tmp_path)
    for kind in ("fifo", "socket", "symlink to a device"):
        link = tmp_path / f"out-{kind.replace(' ', '-')}.png"
        link.symlink_to(specials[kind])
        with no_hang(f"an output that is a {kind}"), pytest.raises(OutputError, match="not a regular file"):
            check_writable(link, (".png",), "output")
    named = tmp_path / "named.png"     # the special file itself, named as an output
    os.mkfifo(named)
    with no_hang("an output that is a FIFO"), pytest.raises(OutputError, match="not a regular file"):
        check_writable(named, (".png",), "output")


def test_json_longer_than_its_limit_is_refused_before_parsing():
    """JSON parsed becomes Python objects several times its size ('[[],[],...]' of 1 GiB: about
    19 GB): a .gltf or a manifest is parsed only up to inputs.MAX_JSON_BYTES of text."""
    from sdfpbr.inputs import MAX_JSON_BYTES, parse_json
    r = rng("json-size")
    for _ in range(SCALE):
        extra = r.randint(1, 1 << 20)
        with pytest.raises(SpecError, match="at most 128 MiB is parsed") as caught:
            parse_json(b"[" + b"[]," * ((MAX_JSON_BYTES + extra) // 3) + b"[]]", "fuzz")
        one_line(caught.value)


# ---- nesting: JSON and TOML of any depth are read or refused in one line --------------------------

def test_deep_nesting_is_refused_in_one_line(tmp_path):
    from sdfpbr.inputs import MAX_NESTING, parse_json
    from sdfpbr.spec.toml_file import read_toml
    r = rng("nesting")
    depths = sorted({r.choice([1, 2, 3, MAX_NESTING - 1, MAX_NESTING, MAX_NESTING + 1, 999, 1000, 1001,
                               r.randint(2, 300), r.randint(300, 200000)]) for _ in range(8 * SCALE)})
    for depth in depths:
        for style in ("array", "table"):
            if style == "array":
                json_text = "[" * depth + "0" + "]" * depth
                toml_text = "x = " + "[" * depth + "0" + "]" * depth + "\n"
            else:
                json_text = '{"a":' * depth + "0" + "}" * depth
                toml_text = "x = " + "{a = " * (depth - 1) + "0" + " }" * (depth - 1) + "\n" if depth > 1 else "x = 0\n"
            # The TOML document's root table counts as one level: x = [[0]] nests 3 deep.
            toml_depth = depth + 1 if style == "array" else depth
            path = tmp_path / f"d{depth}-{style}.toml"
            path.write_text(toml_text)
            for what, read, written in (("JSON", lambda: parse_json(json_text, "fuzz"), depth),
                                        ("TOML", lambda: read_toml(path), toml_depth)):
                if written <= MAX_NESTING:
                    read()
                else:
                    with pytest.raises(SpecError, match="nested more than") as caught:
                        read()
                    one_line(caught.value)


# ---- sizes: an environment of any aspect keeps at least a row and a column ------------------------

def test_environments_of_any_aspect_fit_with_their_mean():
    from sdfpbr.inputs.environment import fit_texture
    r = rng("sizes")
    for _ in range(12 * SCALE):
        limit = r.choice([16, 64, 16384])
        long_side = r.choice([limit + 1, 2 * limit + 1, r.randint(limit + 1, 200000)])
        short = r.randint(1, 4)
        shape = (short, long_side) if r.random() < 0.5 else (long_side, short)
        data = np.random.default_rng(r.randint(0, 2**32 - 1)).random((*shape, 3), dtype=np.float32)
        out = fit_texture(data, limit)
        expect = tuple(min(n, limit) for n in shape)
        assert out.shape[:2] == expect, (shape, limit, out.shape, SEED)
        np.testing.assert_allclose(out.mean(), data.astype(np.float64).mean(), rtol=1e-5)


# ---- paths: confinement against os.path.realpath --------------------------------------------------

SEGMENTS = ["..", ".", "a", "b", "in-link", "out-link", "loop", "%2e%2e", "a%2fb", "", "x.png", "..."]


def tree(tmp: Path) -> tuple[Path, Path]:
    """base/ (with a/, b/, x.png, a link inside and one out, a loop) beside outside/."""
    base, outside = tmp / "base", tmp / "outside"
    (base / "a").mkdir(parents=True)
    (base / "b").mkdir()
    outside.mkdir()
    (base / "x.png").write_bytes(b"x")
    (outside / "x.png").write_bytes(b"secret")
    (base / "in-link").symlink_to(base / "a")
    (base / "out-link").symlink_to(outside)
    (base / "loop").symlink_to(base / "loop")
    return base, outside


def test_confined_paths_never_leave_their_folder(tmp_path):
    from urllib.parse import unquote

    from sdfpbr.inputs import confined
    base, outside = tree(tmp_path)
    root = os.path.realpath(base)
    r = rng("paths")
    for _ in range(300 * SCALE):
        parts = [r.choice(SEGMENTS) for _ in range(r.randint(1, 5))]
        name = "/".join(parts)
        prefix = r.choice(["", "", "", "/", "file:", "file://", "C:", "~/", "\\\\host\\"])
        name = unquote(prefix + name)
        # Joined by pathlib, which drops '.' and doubled '/' (no change of meaning): realpath of
        # 'loop//./' with 'loop' a link to itself gives '/' while 'loop' gives the link.
        real = os.path.realpath(Path(root) / name)
        inside = (prefix == "" and bool(name) and not name.startswith(("/", "~"))
                  and os.path.commonpath([root, real]) == root)
        try:
            got = confined(base, name, "fuzz")
        except SpecError as exc:
            assert not inside, (name, real, SEED)
            assert one_line(exc) == f"fuzz: {name!r} is outside the folder {str(base)!r}; only files inside it are read"
        else:
            assert inside and str(got) == real, (name, got, real, SEED)


def test_gltf_uris_never_read_outside_the_assets_folder(tmp_path):
    """An asset's image uri drawn like the paths above: it charts only when the uri leads to
    the image inside the folder; every other uri is one line, the same whether the outside
    file exists or not (a .gltf written as JSON by hand: no library between)."""
    import json
    from urllib.parse import quote as url_quote

    from sdfpbr.spec.gltf import gltf_materials
    base, outside = tree(tmp_path)
    png = (Path(__file__).parents[1] / "docs" / "clearcoat.png").read_bytes()   # any real PNG
    (base / "x.png").write_bytes(png)
    (base / "a" / "x.png").write_bytes(png)
    (outside / "x.png").write_bytes(png)
    root = os.path.realpath(base)
    r = rng("gltf-paths")
    charted = 0
    for i in range(60 * SCALE):
        parts = [r.choice(SEGMENTS) for _ in range(r.randint(1, 4))] + ["x.png"]
        prefix = r.choice(["", "", "", "/", "file:", "file://", "FILE:", "C:"])
        name = prefix + "/".join(parts)
        uri = url_quote(name, safe="/:%") if r.random() < 0.3 else name   # percent-encoded at times
        real = os.path.realpath(Path(root) / name.replace("%2e", ".").replace("%2f", "/"))
        asset = {"asset": {"version": "2.0"}, "materials": [{"name": "m", "pbrMetallicRoughness": {
                 "baseColorTexture": {"index": 0}}}], "textures": [{"source": 0}], "images": [{"uri": uri}]}
        path = base / f"fuzz{i}.gltf"
        path.write_text(json.dumps(asset))
        inside = prefix == "" and os.path.commonpath([root, real]) == root and os.path.isfile(real)
        try:
            got = gltf_materials(str(path))
        except SpecError as exc:
            assert not inside, (uri, real, SEED)
            one_line(exc)
        else:
            assert inside, (uri, real, SEED)
            assert got.textures[0].base_color.data == png
            charted += 1
        finally:
            path.unlink()
    assert charted, "no uri led inside: the draw reached only refusals"


# ---- cache folders holding other files --------------------------------------------------------------

HEX64 = "0123456789abcdef" * 4


def foreign_names(r: random.Random) -> list[str]:
    """Files a user may keep in a folder SDFPBR_CACHE_DIR names, some named almost as sdfpbr
    names its entries (a hash one short, upper case, an extra suffix, a folder too deep)."""
    kinds = ["ibl", "build", "textures", "stage", "IBL", "notes", "build/stamps", "ibl/deeper"]
    stems = [HEX64[:63], HEX64.upper(), HEX64 + "0", "thesis", "photo", HEX64[:32]]
    suffixes = [".c.npz.bak", ".npz.old", ".pdf", ".jpg", ".png.orig", ".json.txt", ".txt", ""]
    names = [f"{r.choice(kinds)}/{r.choice(stems)}{r.choice(suffixes)}" for _ in range(12)]
    return names + [f"{r.choice(stems)}{r.choice(suffixes)}" for _ in range(4)]


def test_cache_folders_with_foreign_files_keep_them(tmp_path, monkeypatch):
    from sdfpbr.cache import ArrayCache, clear, enforce_cap
    from sdfpbr.features.gallery.images import ImageCache
    r = rng("cache")
    for trial in range(3 * SCALE):
        root = tmp_path / f"cache{trial}"
        planted = {}
        for name in foreign_names(r):
            path = root / name
            if path.exists() or any(p in planted for p in path.parents):
                continue
            path.parent.mkdir(parents=True, exist_ok=True)
            planted[path] = os.urandom(r.randint(0, 3 << 20))
            path.write_bytes(planted[path])
        # Links named exactly as entries, to a file of the user's: a link is never an entry.
        (root / "ibl").mkdir(parents=True, exist_ok=True)
        target = tmp_path / f"precious{trial}.bin"
        planted[target] = os.urandom(1000)
        target.write_bytes(planted[target])
        (root / "ibl" / f"{HEX64}.c.npz").symlink_to(target)
        monkeypatch.setenv("SDFPBR_CACHE_MAX", r.choice(["1", "64K", "1M", "2M"]))
        arrays, images = ArrayCache(root), ImageCache(root)
        for i in range(r.randint(4, 20)):
            arrays.put(r.choice(["ibl", "textures", "dfg"]), f"key{i}",
                       {"a": np.full(r.randint(1, 50000), i, np.float32)})
            images.put(f"{i:064x}", os.urandom(r.randint(10, 100000)))
        enforce_cap(root, r.choice([0, 1, 1 << 20]))
        if r.random() < 0.5:
            clear(root, r.choice([None, "ibl", "build"]))
        for path, data in planted.items():
            assert path.is_file() and path.read_bytes() == data, (str(path), SEED, trial)


# ---- sizes of text: a title or caption is a few lines, not a page ----------------------------------

def test_titles_and_captions_past_their_length_are_refused(tmp_path):
    """A 500 000-character title was set as a 163 x 950196 chart (exit 0). Titles are bounded
    by presets.MAX_TITLE, captions by MAX_CAPTION, on every surface that takes them."""
    from sdfpbr.spec.chart_spec import make_spec
    from sdfpbr.spec.presets import MAX_CAPTION, MAX_TITLE
    from sdfpbr.features.compare import compare_specs
    from sdfpbr.features.gallery.entries import collect
    r = rng("text-size")
    for _ in range(2 * SCALE):
        over = r.randint(1, 10 ** r.randint(0, 6))
        make_spec(title="x" * MAX_TITLE)
        with pytest.raises(SpecError, match=f"title is {MAX_TITLE + over} characters long") as caught:
            make_spec(title="x" * (MAX_TITLE + over))
        one_line(caught.value)
        with pytest.raises(SpecError, match="caption is"):
            compare_specs(make_spec(), make_spec(), caption="y" * (MAX_CAPTION + over))
        (tmp_path / "c.toml").write_text(f'caption = "{"z" * (MAX_CAPTION + over)}"\n')
        with pytest.raises(SpecError, match="caption is"):
            collect(tmp_path)
