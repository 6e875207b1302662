"""An image's cache key: everything that decides its pixels (entry, specs, composed programs,
the Python that makes images, the GL renderer), hashed."""
from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path
from typing import Sequence

from ... import __version__
from ...cache import content_key
from ...spec.chart_spec import ChartSpec
from ...spec.fields import names_file
from .entries import Item

# The modules that make an image; the key hashes them and every sdfpbr module they import.
IMAGE_MODULES = ("sdfpbr.api", "sdfpbr.features.compare")
FORMAT = "sdfpbr-build-1"    # bump when the build changes what it writes into an image
PACKAGE_ROOT = Path(__file__).resolve().parents[2]     # the sdfpbr package directory


def program_sources(spec: ChartSpec) -> list:
    """The composed source of every GL program a render of ``spec`` runs: the render plan's."""
    from ...shading.plan import render_plan
    return render_plan(spec).sources()


def item_modules(item: Item) -> set[str]:
    """Every shader module the item's renders include."""
    return {m for spec in item.specs for src in program_sources(spec) for m in src.modules}


def _file_digest(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _spec_for_key(spec: ChartSpec) -> dict:
    """to_dict, with each named file (env, textures, glTF asset and the files beside it that
    it names: its images may be there) replaced by its content hash, so the key follows what a
    file holds, not where the checkout lives. Every one is read here, memo or not, which is how
    a build's stamp sees them (stamp.py)."""
    out = {}
    for k, v in spec.to_dict().items():
        if names_file(k, v) and Path(v).is_file():
            beside = spec.gltf_maps().files if k == "gltf" else ()
            v = " ".join([f"sha256:{_file_digest(v)}"] + [f"{os.path.relpath(f, Path(v).parent)}:{_file_digest(f)}"
                                                        for f in beside if Path(f).is_file()])
        out[k] = v
    return out


_IMPORT = re.compile(r"^\s*from (\.+)([\w.]*) import ([\w, ()]+)", re.M)


def image_modules() -> list[Path]:
    """The Python sources an image depends on: IMAGE_MODULES and, transitively, every sdfpbr
    module they import (relative imports, resolved across subpackages). A change to any of
    them re-renders; other modules (the CLI, the numpy model, benchmarks) do not."""
    from importlib.util import resolve_name
    package = PACKAGE_ROOT

    def source(dotted: str) -> Path | None:
        base = package.joinpath(*dotted.split(".")[1:])
        for path in (base.with_suffix(".py"), base / "__init__.py"):
            if path.is_file():
                return path
        return None

    seen: dict[str, Path] = {}
    todo = list(IMAGE_MODULES)
    while todo:
        name = todo.pop()
        path = source(name)
        if name in seen or path is None:
            continue
        seen[name] = path
        anchor = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for dots, module, names in _IMPORT.findall(path.read_text()):
            if module:
                todo.append(resolve_name(dots + module, anchor))
            else:   # "from . import a, b": the names may be modules of that package
                pkg = resolve_name(dots, anchor)
                todo += [f"{pkg}.{n.strip(' ()').split(' as ')[0]}" for n in names.split(",") if n.strip(" ()")]
    return [seen[name] for name in sorted(seen)]


_code_digest_memo: str | None = None


def code_digest() -> str:
    """sha256 of image_modules(), computed once per process."""
    global _code_digest_memo
    if _code_digest_memo is None:
        h = hashlib.sha256()
        for path in image_modules():
            h.update(path.relative_to(PACKAGE_ROOT).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
        _code_digest_memo = h.hexdigest()
    return _code_digest_memo


def gl_renderers(items: Sequence[Item]) -> dict[tuple[str, int], str]:
    """The GL renderer string of every (backend, device) the items use; makes the contexts."""
    from ...gpu.session import default_session
    pairs = sorted({(s.backend, s.device_index) for item in items for s in item.specs})
    return {p: default_session(*p).renderer for p in pairs}


def item_key(item: Item, renderers: dict[tuple[str, int], str]) -> str:
    specs = [_spec_for_key(s) for s in item.specs]
    sources = [[src.digest for src in program_sources(s)] for s in item.specs]   # each text hashed once
    gl = sorted({renderers[(s.backend, s.device_index)] for s in item.specs})
    return content_key(FORMAT, __version__, code_digest(), gl, item.kind, item.canonical, specs, sources)


def shader_stamps() -> list:
    """(name, mtime_ns, size) of every shader module, and where they are read from."""
    from ...shading.compose import shader_dir
    root = shader_dir()
    stamps = [str(root)]
    for path in sorted(root.glob("*.glsl")):
        st = path.stat()
        stamps.append((path.name, st.st_mtime_ns, st.st_size))
    return stamps


MEMO_SIZE = 4096   # remembered keys; the oldest go first


def item_keys(items: Sequence[Item], renderers: dict[tuple[str, int], str], memo_path: Path | None) -> dict[str, str]:
    """item_key of every item, by name. Composing every program of a gallery costs ~0.6 s, most
    of a build where nothing changed, so keys are remembered in ``memo_path`` (a JSON file) by
    everything the composition reads instead: the specs and the shader modules' stamps (as
    make does). A touched module recomposes every item, and the key itself stays exact."""
    import json
    from ...errors import SpecError
    from ...inputs import read_json
    stamps = shader_stamps()
    try:   # bounded, as every JSON sdfpbr reads: the memo lies in a shared cache
        memo = read_json(memo_path, "key memo") if memo_path and os.path.lexists(memo_path) else {}
        memo = memo if isinstance(memo, dict) else {}
    except SpecError:
        memo = {}
    keys, changed = {}, False
    for item in items:
        gl = sorted({renderers[(s.backend, s.device_index)] for s in item.specs})
        stamp = content_key(FORMAT, __version__, code_digest(), gl, item.kind, item.canonical,
                            [_spec_for_key(s) for s in item.specs], stamps)
        key = memo.get(stamp)
        if not (isinstance(key, str) and re.fullmatch(r"[0-9a-f]{64}", key)):
            key = memo[stamp] = item_key(item, renderers)
            changed = True
        else:
            memo[stamp] = memo.pop(stamp)     # recently used last
        keys[item.name] = key
    if changed and memo_path:
        from ...errors import OutputError
        from ...files import write_bytes
        memo = dict(list(memo.items())[-MEMO_SIZE:])
        try:
            memo_path.parent.mkdir(parents=True, exist_ok=True)
            write_bytes(memo_path, json.dumps(memo).encode())
        except (OSError, OutputError):
            pass   # an unwritable cache only costs speed
    return keys
