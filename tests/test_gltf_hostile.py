"""glTF assets written to do harm, or written wrong: every refusal is one line (exit status 2 at
the CLI), read before any render, and none of them reads a file outside the asset's folder,
waits on a FIFO, reads without bound, coerces a wrong type into a number or prints the asset's
own text raw.

The assets are written here as raw JSON (a writer would refuse or coerce what they hold), most
checks call spec.gltf.gltf_materials (the whole read happens there), and a few run the CLI."""
import base64
import io
import json
import os
import struct
import subprocess
import sys
import warnings
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from sdfpbr.errors import SpecError
from sdfpbr.spec.gltf import gltf_materials

# Bytes to stand for an image: the read does not decode them (gpu.textures does, at the bake).
IMAGE = b"\x89PNG\r\n\x1a\n not decoded at parse time"
CHART = [sys.executable, "-m", "sdfpbr", "chart"]


def doc(materials=None, **top) -> dict:
    out = {"asset": {"version": "2.0"}, "materials": materials if materials is not None else [{"name": "m"}]}
    out.update(top)
    return out


def textured(uri=None, **material) -> dict:
    """An asset whose one material's base colour samples image 0 (from ``uri``, or a data URI)."""
    uri = uri if uri is not None else "data:image/png;base64," + base64.b64encode(IMAGE).decode()
    m = {"name": "t", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, **material}
    return doc([m], textures=[{"source": 0}], images=[{"uri": uri}])


def buffered(uri, length=len(IMAGE)) -> dict:
    """An asset whose one image lies in buffer 0, read from ``uri``."""
    d = textured()
    d["images"] = [{"bufferView": 0, "mimeType": "image/png"}]
    d["bufferViews"] = [{"buffer": 0, "byteLength": length}]
    d["buffers"] = [{"uri": uri, "byteLength": length}]
    return d


def write(folder: Path, asset: dict, name="a.gltf") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(json.dumps(asset))
    return path


def container(chunks, version=2, length=None) -> bytes:
    """A GLB container of ``chunks`` ((type, bytes) each), its header's total ``length``
    given or true."""
    body = b"".join(struct.pack("<I", len(data)) + kind + data for kind, data in chunks)
    return b"glTF" + struct.pack("<II", version, 12 + len(body) if length is None else length) + body


def glb(asset, blob=b"", version=2, extra=()) -> bytes:
    """A GLB: the JSON chunk, the BIN chunk when ``blob``, then ``extra`` chunks."""
    text = json.dumps(asset).encode() if isinstance(asset, dict) else asset
    chunks = [(b"JSON", text + b" " * (-len(text) % 4))]
    if blob:
        chunks.append((b"BIN\0", blob + b"\0" * (-len(blob) % 4)))
    return container(chunks + list(extra), version)


def refusal(path, names=()) -> str:
    """gltf_materials' one-line refusal of the asset at ``path``."""
    with pytest.raises(SpecError) as info:
        gltf_materials(str(path), names)
    message = str(info.value)
    assert "\n" not in message and "\x1b" not in message, message
    return message


def refused_at_cli(result, out: Path) -> str:
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert not out.exists()
    return lines[0]


def run_main(args) -> tuple[int, str]:
    from sdfpbr.cli.main import main
    err = io.StringIO()
    with redirect_stderr(err), redirect_stdout(io.StringIO()):
        status = main(args)
    return status, err.getvalue()


# ---- 1. confinement ---------------------------------------------------------------------------

def _outside_uri(form: str, secret: Path, folder: Path) -> str:
    if form == "symlink":
        os.symlink(secret, folder / "link.png")
        return "link.png"
    return {"dotdot": "../secret.png", "percent": "%2E%2E/secret.png", "file": secret.as_uri(),
            "absolute": str(secret), "deeper": "maps/../../secret.png"}[form]


@pytest.mark.parametrize("form", ["dotdot", "percent", "file", "absolute", "symlink", "deeper"])
@pytest.mark.parametrize("holder", ["image", "buffer"])
def test_a_uri_leading_outside_the_folder_is_refused_alike_whether_the_file_exists(tmp_path, form, holder):
    """'..', its percent-encoding, a file: URI, an absolute path and a symlink pointing out all
    name a file outside the asset's folder: refused, in words that are the same whether that
    file exists or not (the refusal reveals nothing about the outside)."""
    folder, secret = tmp_path / "asset", tmp_path / "secret.png"
    folder.mkdir()
    (folder / "maps").mkdir()
    uri = _outside_uri(form, secret, folder)
    path = write(folder, textured(uri) if holder == "image" else buffered(uri))
    secret.write_bytes(IMAGE)
    existing = refusal(path)
    secret.unlink()
    missing = refusal(path)
    assert existing == missing and "outside the folder" in existing, (existing, missing)


def test_an_outside_file_at_the_cli_is_one_line_exit_2_and_no_image(tmp_path, cache_dir):
    """The same through `sdfpbr chart`: a real, decodable PNG outside is not charted."""
    import imageio.v3 as iio
    import numpy as np
    secret = tmp_path / "secret.png"
    secret.write_bytes(iio.imwrite("<bytes>", np.full((4, 8, 3), 200, np.uint8), extension=".png"))
    path = write(tmp_path / "asset", textured("../secret.png"))
    out = tmp_path / "out.png"
    r = subprocess.run([*CHART, "--gltf", str(path), "-o", str(out), "--size", "64x64"], capture_output=True,
                       text=True, timeout=120)
    assert "outside the folder" in refused_at_cli(r, out)


def test_data_uris_and_files_inside_the_folder_are_read(tmp_path):
    """What stays inside is read as before: a data URI, a file in a subfolder, a percent-encoded
    name, a symlink to a file inside, and a buffer beside the asset."""
    folder = tmp_path / "asset"
    (folder / "maps").mkdir(parents=True)
    (folder / "maps" / "a b.png").write_bytes(IMAGE + b"1")
    os.symlink(folder / "maps" / "a b.png", folder / "link.png")
    (folder / "data.bin").write_bytes(IMAGE + b"2")
    for uri, want in ((None, IMAGE), ("maps/a%20b.png", IMAGE + b"1"), ("link.png", IMAGE + b"1"),
                      ("./maps/../maps/a%20b.png", IMAGE + b"1")):
        path = write(folder, textured(uri), f"t{len(str(uri))}.gltf")
        assert gltf_materials(str(path)).textures[0].base_color.data == want, uri
    path = write(folder, buffered("data.bin", len(IMAGE) + 1), "b.gltf")
    assert gltf_materials(str(path)).textures[0].base_color.data == IMAGE + b"2"
    path = write(folder, buffered("data:application/octet-stream;base64," + base64.b64encode(IMAGE).decode()), "d.gltf")
    assert gltf_materials(str(path)).textures[0].base_color.data == IMAGE


def test_the_memo_stats_no_file_outside_the_folder(tmp_path, monkeypatch):
    """The memo records the files an asset names (to see them edited): it must not stat one
    outside the folder (its size and time would be known to the process, its existence told by
    timing) before the asset is refused."""
    folder, secret = tmp_path / "asset", tmp_path / "secret.png"
    secret.write_bytes(IMAGE)
    path = write(folder, doc(images=[{"uri": "../secret.png"}], buffers=[{"uri": str(secret), "byteLength": 1}]))
    statted = []
    real_stat = os.stat
    def spy(p, *args, **kwargs):
        statted.append(os.path.realpath(p) if not isinstance(p, int) else p)
        return real_stat(p, *args, **kwargs)
    monkeypatch.setattr(os, "stat", spy)
    refusal(path)
    monkeypatch.setattr(os, "stat", real_stat)
    assert str(secret.resolve()) not in statted, statted


# ---- 2. regular files, bounded -----------------------------------------------------------------

@pytest.mark.parametrize("holder", ["image", "buffer"])
def test_a_fifo_named_by_the_asset_is_refused_without_waiting(tmp_path, cache_dir, holder):
    """A FIFO beside the asset would block its reader for ever (no writer): one line, at once."""
    folder = tmp_path / "asset"
    folder.mkdir()
    os.mkfifo(folder / "pipe.png")
    path = write(folder, textured("pipe.png") if holder == "image" else buffered("pipe.png"))
    out = tmp_path / "out.png"
    r = subprocess.run([*CHART, "--gltf", str(path), "-o", str(out), "--size", "64x64"], capture_output=True,
                       text=True, timeout=60)
    assert "not a regular file" in refused_at_cli(r, out)


READ_ASSET = """
import sys
from sdfpbr.errors import SpecError
from sdfpbr.spec.gltf import gltf_materials
try:
    gltf_materials(sys.argv[1])
except SpecError as exc:
    print(exc)
    sys.exit(2)
"""


@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_the_asset_itself_must_be_a_regular_file_even_through_the_api(tmp_path, kind):
    """gltf_materials, called without the CLI's checks, on a FIFO (which would block) or
    /dev/zero (which never ends): refused in one line. In a process of its own, with its
    address space bounded and a timeout, so a reader that runs on cannot take the machine."""
    import resource
    path = tmp_path / "a.glb"
    if kind == "fifo":
        os.mkfifo(path)
    else:
        os.symlink("/dev/zero", path)
    def bound():
        resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))
    r = subprocess.run([sys.executable, "-c", READ_ASSET, str(path)], capture_output=True, text=True, timeout=60,
                       preexec_fn=bound, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    assert r.returncode == 2 and "not a regular file" in r.stdout and not r.stderr, (r.stdout, r.stderr)


@pytest.mark.parametrize("which", ["asset", "buffer", "image"])
def test_a_file_over_its_kinds_limit_is_refused_from_its_size(tmp_path, monkeypatch, which):
    """The asset and its buffers are read up to the 'gltf' limit, its image files up to the
    'image' limit (sdfpbr.inputs.INPUT_LIMITS, made small here): a larger file is refused by its
    size, named with the limit, not read."""
    from sdfpbr import inputs
    monkeypatch.setitem(inputs.INPUT_LIMITS, "gltf" if which != "image" else "image", 2000)
    folder = tmp_path / "asset"
    folder.mkdir()
    (folder / "big.bin").write_bytes(b"\0" * 4000)
    asset = {"asset": doc(extras={"pad": "x" * 4000}), "buffer": buffered("big.bin", 4000),
             "image": textured("big.bin")}[which]
    message = refusal(write(folder, asset))
    assert "at most" in message and "1.953 KiB" in message, message


@pytest.mark.parametrize("container", ["gltf", "glb"])
def test_json_nested_100000_deep_is_one_line(tmp_path, container):
    """A 100000-deep JSON array (past Python's recursion limit) and a 100-deep one (within it):
    refused for its nesting, in one line, in a .gltf and in a .glb's JSON chunk alike."""
    for depth in (100000, 100):
        text = ('{"asset": {"version": "2.0"}, "materials": [{"name": "m"}], "extras": '
                + "[" * depth + "]" * depth + "}")
        path = tmp_path / f"deep{depth}.{container}"
        path.write_bytes(text.encode() if container == "gltf" else glb(text.encode()))
        assert "nested more than 64 deep" in refusal(path)
    status, err = run_main(["chart", "--gltf", str(path), "-o", str(tmp_path / "x.png")])
    assert status == 2 and len(err.strip().splitlines()) == 1 and "nested" in err, err


# ---- 3. strictness ----------------------------------------------------------------------------

@pytest.mark.parametrize("extension", ["ACME_materials_foo", "KHR_lights_punctual", "MSFT_texture_dds",
                                       "KHR_animation_pointer", "KHR_materials_variants", "KHR_texture_basisu"])
def test_a_required_extension_sdfpbr_cannot_honour_is_refused(tmp_path, extension):
    """A loader must refuse an asset that requires what it does not implement (glTF 2.0, 3.12):
    a vendor's material extension as much as a KHR one, and one of lights or animation."""
    path = write(tmp_path, doc(extensionsRequired=[extension], extensionsUsed=[extension]))
    assert f"requires {extension!r}, which sdfpbr does not chart" in refusal(path)


def test_the_required_extensions_sdfpbr_honours_are_charted(tmp_path):
    """What it charts, KHR_texture_transform, and what changes only meshes, which a chart of
    materials never reads."""
    honoured = ["KHR_materials_clearcoat", "KHR_materials_sheen", "KHR_materials_specular", "KHR_materials_ior",
                "KHR_materials_emissive_strength", "KHR_texture_transform", "KHR_draco_mesh_compression",
                "KHR_mesh_quantization", "EXT_meshopt_compression"]
    path = write(tmp_path, doc(extensionsRequired=honoured, extensionsUsed=honoured))
    assert len(gltf_materials(str(path)).materials) == 1


@pytest.mark.parametrize("key", ["extensionsRequired", "extensionsUsed"])
@pytest.mark.parametrize("value", ["KHR_materials_transmission", [1], ["KHR_texture_transform", None],
                                   {"KHR_materials_transmission": True}])
def test_extension_lists_that_are_not_lists_of_strings_are_refused(tmp_path, key, value):
    path = write(tmp_path, doc(**{key: value}))
    assert f"{key} " in refusal(path) and "list of extension names" in refusal(path)


def _set(asset: dict, where: str, value) -> dict:
    """asset with the value at ``where`` ('materials.0.pbrMetallicRoughness.metallicFactor')."""
    *parents, last = where.split(".")
    node = asset
    for key in parents:
        node = node[int(key)] if isinstance(node, list) else node.setdefault(key, {})
    node[int(last) if isinstance(node, list) else last] = value
    return asset


def _full() -> dict:
    """An asset that reads every field below: factors, textures with a sampler, a buffer."""
    d = buffered("data:application/octet-stream;base64," + base64.b64encode(IMAGE).decode())
    m = d["materials"][0]
    m["pbrMetallicRoughness"].update(baseColorFactor=[1, 1, 1, 1], metallicFactor=0, roughnessFactor=1)
    m.update(normalTexture={"index": 0, "scale": 1}, occlusionTexture={"index": 0, "strength": 1},
             emissiveFactor=[0, 0, 0], alphaMode="MASK", alphaCutoff=0.5,
             extensions={"KHR_materials_clearcoat": {"clearcoatFactor": 1, "clearcoatTexture": {"index": 0}},
                         "KHR_materials_emissive_strength": {"emissiveStrength": 2}})
    d["textures"][0]["sampler"] = 0
    d["samplers"] = [{"wrapS": 10497, "magFilter": 9729}]
    return d


WRONG_TYPES = [
    ("materials.0.pbrMetallicRoughness.metallicFactor", "1"),
    ("materials.0.pbrMetallicRoughness.metallicFactor", True),
    ("materials.0.pbrMetallicRoughness.roughnessFactor", "0.5"),
    ("materials.0.pbrMetallicRoughness.baseColorFactor", ["1", 1, 1, 1]),
    ("materials.0.pbrMetallicRoughness.baseColorFactor", [True, 1, 1, 1]),
    ("materials.0.pbrMetallicRoughness.baseColorFactor", "1111"),
    ("materials.0.emissiveFactor", "000"),
    ("materials.0.alphaCutoff", "0.5"),
    ("materials.0.normalTexture.scale", "1"),
    ("materials.0.occlusionTexture.strength", True),
    ("materials.0.pbrMetallicRoughness.baseColorTexture.index", "0"),
    ("materials.0.pbrMetallicRoughness.baseColorTexture.index", 0.0),
    ("materials.0.extensions.KHR_materials_clearcoat.clearcoatFactor", "1"),
    ("materials.0.extensions.KHR_materials_emissive_strength.emissiveStrength", True),
    ("materials.0.name", 5),
    ("materials.0.pbrMetallicRoughness", [1]),
    ("materials.0.extensions", "KHR_materials_clearcoat"),
    ("textures.0.source", "0"),
    ("textures.0.sampler", 0.0),
    ("samplers.0.wrapS", "10497"),
    ("samplers.0.magFilter", 9729.0),
    ("images.0.bufferView", "0"),
    ("bufferViews.0.buffer", "0"),
    ("bufferViews.0.byteLength", 2.7e1),
    ("bufferViews.0.byteOffset", "0"),
    ("asset.version", 2.0),
]


@pytest.mark.parametrize("where, value", WRONG_TYPES, ids=[f"{w.split('.')[-1]}={v!r}" for w, v in WRONG_TYPES])
def test_a_value_of_the_wrong_type_is_refused_not_coerced(tmp_path, where, value):
    """JSON says what type each value is: a string, a boolean or a float where glTF has a
    number or an index is the asset's error, refused naming the key, never read as 1.0 (a
    dataclass decoder's float("1"), float(True), int(27.0), list("000") would)."""
    assert len(gltf_materials(str(write(tmp_path, _full(), "fine.gltf"))).materials) == 1
    message = refusal(write(tmp_path, _set(_full(), where, value)))
    assert where.split(".")[-1] in message, message


@pytest.mark.parametrize("where, key", [("materials.0.pbrMetallicRoughness.metallicFactor", "metallicFactor"),
                                        ("materials.0.emissiveFactor.1", "emissiveFactor"),
                                        ("materials.0.normalTexture.scale", "scale"),
                                        ("bufferViews.0.byteLength", "byteLength"),
                                        ("materials.0.pbrMetallicRoughness.baseColorTexture.index", "index")])
def test_a_whole_number_too_large_for_a_float_is_one_line(tmp_path, where, key):
    """JSON's numbers have no bound: 10^400 (an int to Python, no float) is refused, named, in a
    message kept short."""
    message = refusal(write(tmp_path, _set(_full(), where, 10 ** 400)))
    assert key in message and len(message) < 300, message


@pytest.mark.parametrize("version", [1, 3, 0])
def test_a_glb_container_of_another_version_is_refused(tmp_path, version):
    path = tmp_path / "a.glb"
    path.write_bytes(glb(doc(), version=version))
    assert f"GLB container version {version}" in refusal(path)
    path.write_bytes(glb(doc(), version=2))
    assert len(gltf_materials(str(path)).materials) == 1


@pytest.mark.parametrize("damage", ["short", "length", "chunk", "no json", "bin first", "not json"])
def test_a_damaged_glb_container_is_one_line(tmp_path, damage):
    """A header cut short, a total length or chunk length past the file's end, no JSON chunk,
    the BIN chunk first, a JSON chunk that is not JSON: one line each."""
    text = json.dumps(doc()).encode()
    text += b" " * (-len(text) % 4)
    data = {"short": glb(doc())[:10],
            "length": container([(b"JSON", text)], length=12 + 8 + len(text) + 4),
            "chunk": b"glTF" + struct.pack("<III", 2, 20 + len(text), len(text) + 100) + b"JSON" + text,
            "no json": container([]),
            "bin first": container([(b"BIN\0", b"1234"), (b"JSON", text)]),
            "not json": container([(b"JSON", b"\xff\xfe{]  ")])}[damage]
    path = tmp_path / "a.glb"
    path.write_bytes(data)
    assert "cannot be read as glTF 2.0" in refusal(path)


def test_no_library_warning_reaches_the_user(tmp_path, capfd):
    """A GLB with a chunk of an unknown type (glTF: ignored) and a .gltf without an asset
    object: whatever a parser has to say becomes a refusal or nothing, never a warning naming
    site-packages on stderr."""
    good = tmp_path / "a.glb"
    good.write_bytes(glb(doc(), blob=IMAGE, extra=[(b"XTRA", b"abcd")]))
    bad = write(tmp_path, {"materials": [{"name": "m"}]})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert len(gltf_materials(str(good)).materials) == 1
        assert "asset" in refusal(bad)
    assert [str(w.message) for w in caught] == []
    assert capfd.readouterr().err == ""


def test_asset_text_in_notes_and_messages_is_quoted_with_controls_escaped(tmp_path):
    """A material's name, an extension's name and a uri are the asset's text: every note and
    message quotes them with control characters escaped (a terminal would run ESC [31m, a
    newline would make two lines)."""
    name = "red\x1b[31m\nline"
    asset = doc([{"name": name, "extensions": {"KHR_materials_transmission": {}, "X_\x1b]0;owned\x07": {}}}])
    path = write(tmp_path, asset)
    notes = gltf_materials(str(path)).ignored
    assert len(notes) == 2 and all("\x1b" not in n and "\n" not in n and "\x07" not in n for n in notes), notes
    assert "'red\\x1b[31m\\nline'" in notes[0] and "KHR_materials_transmission" in notes[0], notes
    assert "\\x1b]0;owned\\x07" in notes[1], notes
    assert "\\x1b" in refusal(path, ("nope",))
    assert "\\x1b" in refusal(write(tmp_path, textured("gone\x1b[2J.png"), "b.gltf"))


def test_an_escaped_note_at_the_cli(tmp_path, cache_dir):
    """The one render here: the CLI's note on what is not charted shows the name escaped."""
    path = write(tmp_path, doc([{"name": "x\x1b[31m", "extensions": {"KHR_materials_transmission": {}}}]))
    out = tmp_path / "out.png"
    r = subprocess.run([*CHART, "--gltf", str(path), "-o", str(out), "--size", "64x64"], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0 and out.exists(), r.stderr
    assert "\x1b" not in r.stderr and "'x\\x1b[31m'" in r.stderr and "is not charted" in r.stderr, r.stderr
