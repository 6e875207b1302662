"""Gallery builds: render every entry of a directory of TOML files through a content-addressed
image cache, then write the images, ``manifest.json`` and a static ``index.html``.

Entries
-------
Every ``*.toml`` file directly in the chart directory is an entry (sub-directories are not
scanned, so they can hold specs that entries refer to). ``OUT/<file stem>.png`` is its image.

* **Chart**: a plain chart spec, exactly as ``sdfpbr chart --spec`` reads it, plus an optional
  top-level ``caption = "..."`` (the gallery's text; not drawn into the chart)::

      rows = 5
      row_materials = ["gold", "copper", "silver", "iron", "aluminium"]
      metallic = "1:1"
      caption = "Measured metals."

* **Comparison**: a ``[compare]`` table, an optional ``[spec]`` table (the base spec, as the
  keys of a chart entry) and an optional ``caption``. ``[compare]`` holds exactly one of

  - ``bug = "unsquared-roughness"``: correct | buggy | FLIP difference of one catalog bug;
  - ``bugs = "all"`` or ``bugs = ["name", ...]``: one contact sheet of those bugs;
  - ``bugs = "each"``: one comparison per catalog bug, written as ``<stem>-<bug>.png``;
  - ``a = "x.toml"`` and ``b = "y.toml"`` (paths relative to the entry; ``[spec]`` is the base
    both files are read over), with optional ``labels = ["A", "B"]``.

* **Sweep**: ``[sweep] field = "tonemap"`` and ``values = [...]`` (any spec key; each value as it
  would be written in a chart entry), with an optional ``[spec]`` base and ``caption``.

An ``env`` file named in an entry is found relative to the entry's directory.

Cache
-----
An image's key is the sha256 of: the entry document (canonical JSON), every spec the image
renders (``to_dict``; a file the spec names is hashed by content), the composed source of every
GL program those renders run (chart, display, vertex, DFG and IBL bakes; pure Python), the
sdfpbr version, the Python sources that make images (``image_modules()``: chart, compare and
every sdfpbr module they import) and the GL renderer string. Images live in
``<cache>/build/<key>.png`` (``$SDFPBR_CACHE_DIR`` or ~/.cache/sdfpbr) with the key in their
PNG metadata; a rebuild renders only the images no valid entry exists for, so editing one
shader module re-renders exactly the images whose programs include it.

Output
------
``OUT/<name>.png`` per image (byte-identical to its cache entry), ``OUT/manifest.json`` (per
image: file, entry, kind, caption, parameters, key, cached, size, sha256, timings, specs) and
``OUT/index.html`` (every image with its caption and parameters). ``-j N`` renders in N spawned
processes, each with its own GL context; the main process alone writes files.

Interruption and concurrency
----------------------------
Every file (cache entry, image, manifest, index) is written to a temporary name carrying the
writer's pid in the destination directory, fsynced, and renamed into place. A rename is atomic
on one filesystem, so a reader sees either no file or a complete one, never a torn one; a build
killed at any point leaves at most temporary files, which the next build removes once their
writer's process is gone. A cache entry is also verified on read (it must decode and carry its
own key), so even a damaged file only costs a re-render. Two builds sharing a cache may render
the same key at the same time: both write identical bytes (renders are deterministic) and
whichever rename lands last wins, so every reader still gets a valid entry. Builds writing to
one output directory at the same time are not coordinated beyond that (the last manifest wins).
"""
from __future__ import annotations

import hashlib
import html
import io as _io
import json
import os
import re
import signal
import sys
import threading
import time
import tomllib
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence
from urllib.parse import quote

from .. import __version__
from ..cache import content_key, default_cache_dir
from ..errors import OutputError, SdfpbrError, SpecError
from ..image.io import atomic_path
from ..spec.chart_spec import ENV_PRESETS, ChartSpec, load_spec, spec_from_mapping

KEY_FIELD = "sdfpbr:build-key"
ENTRY_FIELD = "sdfpbr:gallery-entry"
# The modules that make an image; the key hashes them and every sdfpbr module they import.
_IMAGE_MODULES = ("sdfpbr.api", "sdfpbr.tools.compare")
FORMAT = "sdfpbr-build-1"    # bump when this module changes what it writes into an image
_TEMP = re.compile(r"^\..+\.(\d+)\.tmp$")   # ".<name>.<random>.<pid>.tmp", see _write_atomic
KILL_ENV = "SDFPBR_BUILD_KILL_AT"           # test hook, "phase:n", see _checkpoint


# ---------------------------------------------------------------------------------------------
# Entries.

@dataclass(frozen=True)
class Item:
    """One image of a gallery, fully resolved: what to render and everything its key covers."""
    name: str                       # output stem: OUT/<name>.png
    entry: str                      # where it came from (file name, or docname:line)
    kind: str                       # chart, compare, compare-specs, bug-sheet or sweep
    document: dict                  # the entry document this image is made from
    specs: tuple[ChartSpec, ...]    # every spec the image renders
    caption: str
    params: dict                    # what the gallery prints beside the image
    base: ChartSpec | None = None   # comparisons and sweeps: the [spec] base
    bug: str = ""                   # compare: the bug
    bug_names: tuple[str, ...] = ()
    labels: tuple[str, ...] = ()
    sweep_field: str = ""
    sweep_values: tuple = ()

    @property
    def canonical(self) -> str:
        return json.dumps(self.document, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str)


def _catalog():
    try:
        from ..spec import bugs
    except ImportError:
        raise SpecError("comparison entries need the bug catalog (sdfpbr.bugs), which this install lacks") from None
    return bugs


def _spec_overrides(spec: ChartSpec) -> dict:
    """The keys where ``spec`` differs from the defaults: a short parameter list for people."""
    default = ChartSpec().to_dict()
    return {k: v for k, v in spec.to_dict().items() if default.get(k) != v}


def _resolve_env(mapping: dict, base_dir: Path) -> dict:
    """A relative env file in an entry is relative to the entry, not to the working directory."""
    env = mapping.get("env")
    if isinstance(env, str) and env not in ENV_PRESETS and not Path(env).is_absolute():
        candidate = base_dir / env
        if candidate.exists():
            return {**mapping, "env": str(candidate)}
    return mapping


def _table(data: dict, key: str, where: str) -> dict:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise SpecError(f"{where}: {key} must be a table ([{key}]), got {value!r}")
    return value


def _text(value, what: str, where: str) -> str:
    if not isinstance(value, str):
        raise SpecError(f"{where}: {what} must be text, got {value!r}")
    return value


def parse_entry(data: dict, where: str, base_dir: Path, stem: str) -> list[Item]:
    """The images one entry document describes. Raises SpecError naming ``where``."""
    caption = _text(data.get("caption", ""), "caption", where)
    sections = [k for k in ("compare", "sweep") if k in data]
    if len(sections) > 1:
        raise SpecError(f"{where}: an entry has either [compare] or [sweep], not both")
    if not sections:
        if "spec" in data:
            raise SpecError(f"{where}: [spec] belongs to [compare] or [sweep] entries; "
                            f"a chart entry puts its spec keys at the top level")
        mapping = {k: v for k, v in data.items() if k != "caption"}
        spec = spec_from_mapping(_resolve_env(mapping, base_dir), where=where)
        return [Item(stem, where, "chart", data, (spec,), caption or spec.title,
                     {"spec": _spec_overrides(spec)})]
    section = sections[0]
    extra = sorted(set(data) - {"caption", "spec", section})
    if extra:
        raise SpecError(f"{where}: unknown top-level key {extra[0]!r} in a [{section}] entry; "
                        f"allowed: caption, spec, {section}")
    base = spec_from_mapping(_resolve_env(_table(data, "spec", where), base_dir), where=f"{where} [spec]")
    table = _table(data, section, where)
    if section == "sweep":
        return [_sweep_item(data, table, base, caption, where, stem)]
    return _compare_items(data, table, base, caption, where, base_dir, stem)


def _sweep_item(data, table, base, caption, where, stem) -> Item:
    unknown = sorted(set(table) - {"field", "values"})
    if unknown:
        raise SpecError(f"{where}: unknown [sweep] key {unknown[0]!r}; allowed: field, values")
    name = _text(table.get("field"), "[sweep] field", where)
    values = table.get("values")
    if not isinstance(values, list) or not values:
        raise SpecError(f"{where}: [sweep] values must be a non-empty list, got {values!r}")
    attr = name.replace("-", "_")
    if attr == "size":
        raise SpecError(f"{where}: sweep width or height, not size")
    specs, parsed = [], []
    for value in values:
        spec = spec_from_mapping({name: value}, base, where=f"{where} [sweep]")
        specs.append(spec)
        parsed.append(getattr(spec, attr))
    default = caption or f"The same chart across {attr.replace('_', ' ')}: {', '.join(map(str, values))}."
    return Item(stem, where, "sweep", data, tuple(specs), default,
                {"sweep": attr, "values": values, "spec": _spec_overrides(base)}, base,
                sweep_field=attr, sweep_values=tuple(parsed))


def _compare_items(data, table, base, caption, where, base_dir, stem) -> list[Item]:
    unknown = sorted(set(table) - {"bug", "bugs", "a", "b", "labels"})
    if unknown:
        raise SpecError(f"{where}: unknown [compare] key {unknown[0]!r}; allowed: bug, bugs, a, b, labels")
    forms = [k for k in ("bug", "bugs", "a") if k in table]
    if len(forms) != 1 or (("a" in table) != ("b" in table)):
        raise SpecError(f"{where}: [compare] needs exactly one of bug = NAME, bugs = \"all\"|\"each\"|[NAMES], "
                        f"or a = FILE and b = FILE")
    overrides = _spec_overrides(base)
    if "a" in table:
        paths = [_text(table[k], f"[compare] {k}", where) for k in ("a", "b")]
        labels = table.get("labels", [Path(p).stem for p in paths])
        if not (isinstance(labels, list) and len(labels) == 2 and all(isinstance(s, str) for s in labels)):
            raise SpecError(f"{where}: [compare] labels must be two strings, got {labels!r}")
        specs = tuple(load_spec(_resolve_file(p, base_dir, where), base) for p in paths)
        default = caption or f"{labels[0]} vs {labels[1]}."
        return [Item(stem, where, "compare-specs", data, specs, default,
                     {"a": paths[0], "b": paths[1], "spec": overrides}, base, labels=tuple(labels))]
    if "labels" in table:
        raise SpecError(f"{where}: [compare] labels go with a and b")
    bugs = _catalog()
    if "bug" in table:
        bug = _bug(bugs, table["bug"], where)
        return [_bug_item(stem, where, data, base, bug, caption, overrides)]
    names = table["bugs"]
    if names == "each":
        items = []
        for bug in bugs.BUGS.values():
            doc = {**data, "compare": {"bug": bug.name}}
            items.append(_bug_item(f"{stem}-{bug.name}", where, doc, base, bug, caption, overrides))
        return items
    if names == "all":
        chosen = list(bugs.BUGS.values())
    elif isinstance(names, list) and names:
        chosen = [_bug(bugs, n, where) for n in names]
    else:
        raise SpecError(f"{where}: [compare] bugs must be \"all\", \"each\" or a list of bug names, got {names!r}")
    specs = [s for bug in chosen for s in _bug_specs(base, bug.name)]
    unique = tuple({json.dumps(s.to_dict(), sort_keys=True, default=str): s for s in specs}.values())
    default = caption or "Every bug of the catalog against the correct chart."
    return [Item(stem, where, "bug-sheet", data, unique, default,
                 {"bugs": [b.name for b in chosen], "spec": overrides}, base,
                 bug_names=tuple(b.name for b in chosen))]


def _bug(bugs, name, where):
    if not isinstance(name, str):
        raise SpecError(f"{where}: a bug name must be text, got {name!r}")
    try:
        return bugs.get_bug(name)
    except SpecError as exc:
        raise SpecError(f"{where}: {exc}") from None


def _bug_specs(base: ChartSpec, name: str) -> tuple[ChartSpec, ChartSpec]:
    """(correct, buggy) exactly as the comparison renders them."""
    from .compare import bug_pair
    _, correct, buggy = bug_pair(base, name)
    return correct, buggy


def _bug_item(name, where, doc, base, bug, caption, overrides) -> Item:
    specs = _bug_specs(base, bug.name)
    return Item(name, where, "compare", doc, specs, caption or bug.caption,
                {"bug": bug.name, "summary": bug.summary, "spec": overrides}, base, bug=bug.name)


def _resolve_file(path: str, base_dir: Path, where: str) -> Path:
    p = Path(path)
    p = p if p.is_absolute() else base_dir / p
    if not p.is_file():
        raise SpecError(f"{where}: [compare] file {path} does not exist (relative to {base_dir})")
    return p


def load_entry(path: Path) -> list[Item]:
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(f"cannot read entry {path}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{path}: malformed TOML: {exc}") from None
    return parse_entry(data, str(path), path.parent, path.stem)


def collect(chart_dir: str | Path) -> list[Item]:
    """Every image of the gallery in ``chart_dir``, validated before anything is rendered."""
    root = Path(chart_dir)
    if not root.is_dir():
        raise SpecError(f"chart directory {root} does not exist" if not root.exists()
                        else f"{root} is not a directory of chart entries")
    files = sorted(p for p in root.glob("*.toml") if p.is_file())
    if not files:
        raise SpecError(f"{root} holds no *.toml chart entries")
    items, seen = [], {}
    for path in files:
        for item in load_entry(path):
            if item.name in seen:
                raise SpecError(f"{path}: image {item.name}.png is also made by {seen[item.name]}")
            seen[item.name] = path.name
            items.append(item)
    return items


# ---------------------------------------------------------------------------------------------
# Keys.

def program_sources(spec: ChartSpec) -> list:
    """The composed source of every GL program a render of ``spec`` runs (mirrors render.py
    and ibl.py; tests check it covers every program a real render compiles)."""
    from ..shading.compose import compose
    from ..gpu.render import chart_source, display_source
    chart = chart_source(spec)
    opts = dict(chart.options)
    dfg_opts = {"BRDF_MODEL": opts["BRDF_MODEL"]}
    if opts.get("BUG_IBL_DIRECT_K"):
        dfg_opts["BUG_IBL_DIRECT_K"] = True
    sources = [compose("fullscreen_vert.glsl"), chart, display_source(spec), compose("dfg_main.glsl", dfg_opts)]
    if spec.ibl and not opts.get("BUG_FEWTAP_IBL"):
        bake_opts = {"ENV": opts["ENV"], "BRDF_MODEL": opts["BRDF_MODEL"]}
        sources += [compose("bake_env_main.glsl", bake_opts), compose("prefilter_main.glsl", bake_opts),
                    compose("sh_main.glsl"),
                    compose("copy_cube_main.glsl", {"COPY_DIRECTION": "to_cube"}),
                    compose("copy_cube_main.glsl", {"COPY_DIRECTION": "from_cube"})]
    return sources


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
    """to_dict, with each named file (env, textures) replaced by its content hash, so the key
    follows what a file holds, not where the checkout lives."""
    out = {}
    for k, v in spec.to_dict().items():
        names_file = k == "env" and v not in ENV_PRESETS or k.endswith("_texture")
        if names_file and isinstance(v, str) and v and Path(v).is_file():
            v = "sha256:" + _file_digest(v)
        out[k] = v
    return out


_IMPORT = re.compile(r"^\s*from (\.+)([\w.]*) import ([\w, ()]+)", re.M)


def image_modules() -> list[Path]:
    """The Python sources an image depends on: _IMAGE_MODULES and, transitively, every sdfpbr
    module they import (relative imports, resolved across subpackages). A change to any of
    them re-renders; other modules (the CLI, the numpy mirror, benchmarks) do not."""
    from importlib.util import resolve_name
    package = Path(__file__).resolve().parents[1]

    def source(dotted: str) -> Path | None:
        base = package.joinpath(*dotted.split(".")[1:])
        for path in (base.with_suffix(".py"), base / "__init__.py"):
            if path.is_file():
                return path
        return None

    seen: dict[str, Path] = {}
    todo = list(_IMAGE_MODULES)
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
            h.update(path.relative_to(Path(__file__).resolve().parents[1]).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
        _code_digest_memo = h.hexdigest()
    return _code_digest_memo


def gl_renderers(items: Sequence[Item]) -> dict[tuple[str, int], str]:
    """The GL renderer string of every (backend, device) the items use; makes the contexts."""
    from ..api import get_renderer
    from ..gpu.gl import renderer_string
    pairs = sorted({(s.backend, s.device_index) for item in items for s in item.specs})
    return {p: renderer_string(get_renderer(*p).ctx) for p in pairs}


def item_key(item: Item, renderers: dict[tuple[str, int], str]) -> str:
    specs = [_spec_for_key(s) for s in item.specs]
    sources = [[src.text for src in program_sources(s)] for s in item.specs]
    gl = sorted({renderers[(s.backend, s.device_index)] for s in item.specs})
    return content_key(FORMAT, __version__, code_digest(), gl, item.kind, item.canonical, specs, sources)


# ---------------------------------------------------------------------------------------------
# Files: atomic writes, the image cache.

_hits: Counter = Counter()


def _checkpoint(phase: str) -> None:
    """Test hook: with $SDFPBR_BUILD_KILL_AT = "phase:n" the process SIGKILLs itself the n-th
    time it reaches ``phase`` (render, cache-temp, cache, output-temp, output, manifest-temp,
    manifest), so tests can interrupt a build at exact points with a real kill."""
    want = os.environ.get(KILL_ENV)
    if not want:
        return
    name, _, count = want.partition(":")
    if name == phase:
        _hits[phase] += 1
        if _hits[phase] >= int(count or 1):
            os.kill(os.getpid(), signal.SIGKILL)


def _write_atomic(path: Path, data: bytes, phase: str) -> None:
    """Write beside ``path`` under a name carrying our pid, fsync, rename into place."""
    with atomic_path(path, suffix=f".{os.getpid()}.tmp") as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        _checkpoint(phase + "-temp")
    _checkpoint(phase)


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:          # exists, owned by someone else
        return True
    return True


def remove_stale_temps(directory: Path) -> int:
    """Delete temporary files of writers that no longer run (a killed build); a live writer's
    temporaries are left alone, so builds sharing a directory cannot hurt each other."""
    removed = 0
    try:
        names = os.listdir(directory)
    except OSError:
        return 0
    for name in names:
        m = _TEMP.match(name)
        if m and not _alive(int(m.group(1))):
            try:
                os.unlink(directory / name)
                removed += 1
            except OSError:
                pass
    return removed


def png_key(data: bytes) -> str | None:
    """The build key stored in a PNG, or None if the bytes are not a complete, valid PNG."""
    from PIL import Image
    try:
        with Image.open(_io.BytesIO(data)) as im:
            im.load()   # decodes every row: a truncated or damaged file fails here
            return im.text.get(KEY_FIELD)
    except Exception:
        return None


class ImageCache:
    """Rendered images by key in ``<root>/build``; an entry is used only if it verifies."""

    def __init__(self, root: str | Path | None = None):
        self.dir = Path(root or default_cache_dir()) / "build"

    def path(self, key: str) -> Path:
        return self.dir / f"{key}.png"

    def get(self, key: str) -> bytes | None:
        try:
            data = self.path(key).read_bytes()
        except OSError:
            return None
        return data if png_key(data) == key else None

    def put(self, key: str, data: bytes) -> bool:
        """Best effort: an unwritable cache only costs speed."""
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
            _write_atomic(self.path(key), data, "cache")
            return True
        except (OSError, OutputError):
            return False

    def remove_stale_temps(self) -> int:
        return remove_stale_temps(self.dir)


# ---------------------------------------------------------------------------------------------
# Rendering one item.

@dataclass
class Rendered:
    png: bytes
    seconds: float
    renderer: str
    timings: dict = field(default_factory=dict)


def render_item(item: Item, key: str) -> Rendered:
    """Render ``item`` on this process's GL context into PNG bytes carrying ``key``."""
    from ..image.io import png_bytes
    start = time.perf_counter()
    timings = {}
    if item.kind == "chart":
        from ..api import chart
        result = chart(item.specs[0])
        image, metadata, renderer = result.image, result.metadata(), result.renderer
        timings = {k: round(v, 4) for k, v in result.result.timings.items()}
    else:
        from . import compare
        if item.kind == "compare":
            sheet = compare.compare_bug(item.base, item.bug)
        elif item.kind == "bug-sheet":
            # panel_size = the base's own size: the entry's [spec] decides the panels.
            sheet = compare.bug_contact_sheet(item.base, list(item.bug_names),
                                              panel_size=max(item.base.width, item.base.height))
        elif item.kind == "compare-specs":
            sheet = compare.compare_specs(item.specs[0], item.specs[1], labels=item.labels, caption=item.caption)
        else:
            sheet = compare.sweep(item.base, item.sweep_field, list(item.sweep_values))
        image, metadata, renderer = sheet.image, sheet.metadata(), sheet.renderer
    metadata = {**metadata, KEY_FIELD: key, ENTRY_FIELD: item.canonical}
    data = png_bytes(image, metadata)
    return Rendered(data, time.perf_counter() - start, renderer, timings)


def _worker_init(parent: int) -> None:
    """Workers of a killed build exit on their own instead of rendering for nobody."""
    def watch():
        while True:
            time.sleep(0.5)
            if os.getppid() != parent:
                os._exit(1)
    threading.Thread(target=watch, daemon=True).start()


def _worker(item: Item, key: str) -> Rendered:
    return render_item(item, key)


# ---------------------------------------------------------------------------------------------
# The build.

@dataclass
class Result:
    item: Item
    key: str
    cached: bool
    png: bytes
    seconds: float = 0.0
    timings: dict = field(default_factory=dict)


def ensure_image(item: Item, cache: ImageCache | None = None, force: bool = False,
                 renderers: dict | None = None) -> tuple[str, bytes, bool]:
    """One item through the cache in this process: (key, PNG bytes, whether it was cached).
    The Sphinx extension uses this."""
    cache = cache or ImageCache()
    key = item_key(item, renderers or gl_renderers([item]))
    data = None if force else cache.get(key)
    if data is not None:
        return key, data, True
    rendered = render_item(item, key)
    cache.put(key, rendered.png)
    return key, rendered.png, False


Progress = Callable[[str], None]


def build(chart_dir: str | Path, out_dir: str | Path, jobs: int = 1, force: bool = False,
          progress: Progress | None = None, verbose: bool = False) -> dict:
    """Build the gallery of ``chart_dir`` into ``out_dir``; returns the manifest."""
    start = time.perf_counter()
    say = progress or (lambda line: None)
    items = collect(chart_dir)                      # every entry validated before any output
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise OutputError(f"output {out} exists and is not a directory")
    if not out.exists() and not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise OutputError(f"cannot create output directory {out}: {out.parent} does not exist")
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 0:
        raise SpecError(f"-j must be a whole number >= 0 (0: one per CPU), got {jobs!r}")
    jobs = jobs or os.cpu_count() or 1

    renderers = gl_renderers(items)
    keys = {item.name: item_key(item, renderers) for item in items}
    cache = ImageCache()
    cache.remove_stale_temps()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create output directory {out}: {exc.strerror or exc}") from None
    remove_stale_temps(out)
    previous = _previous_images(out)

    results: dict[str, Result] = {}
    todo: list[Item] = []
    total = len(items)
    for item in items:
        data = None if force else cache.get(keys[item.name])
        if data is None:
            todo.append(item)
            continue
        results[item.name] = Result(item, keys[item.name], True, data)
        _write_output(out, item, data)
        say(f"[{len(results):{len(str(total))}d}/{total}] {item.name}.png  cached"
            + (f"  {keys[item.name][:12]}" if verbose else ""))

    def done(item: Item, rendered: Rendered) -> None:
        key = keys[item.name]
        _checkpoint("render")
        if rendered.renderer and rendered.renderer not in renderers.values():
            # Rendered on another GL than the key says: use the image, but do not cache it.
            say(f"warning: {item.name} rendered on {rendered.renderer}, not caching it")
        else:
            cache.put(key, rendered.png)
        results[item.name] = Result(item, key, False, rendered.png, rendered.seconds, rendered.timings)
        _write_output(out, item, rendered.png)
        say(f"[{len(results):{len(str(total))}d}/{total}] {item.name}.png  rendered in {rendered.seconds:.2f} s"
            + (f"  {key[:12]}" if verbose else ""))

    workers = min(jobs, len(todo))
    if workers <= 1:
        for item in todo:
            done(item, render_item(item, keys[item.name]))
    else:
        _render_parallel(todo, keys, workers, done)

    manifest = _manifest(items, results, renderers, chart_dir, time.perf_counter() - start)
    _write_atomic(out / "manifest.json", (json.dumps(manifest, indent=2, ensure_ascii=False) + "\n").encode(), "manifest")
    _write_atomic(out / "index.html", gallery_html(manifest).encode(), "index")
    for name in previous - {f"{item.name}.png" for item in items}:
        try:
            (out / name).unlink()     # an image of an entry that no longer exists
        except OSError:
            pass
    return manifest


def _render_parallel(todo: list[Item], keys: dict, workers: int, done) -> None:
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool
    # spawn: each worker starts clean and makes its own GL context (no GL state is forked).
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(workers, mp_context=context, initializer=_worker_init,
                             initargs=(os.getpid(),)) as pool:
        futures = {pool.submit(_worker, item, keys[item.name]): item for item in todo}
        pending = set(futures)
        try:
            while pending:
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in finished:
                    done(futures[future], future.result())
        except BrokenProcessPool:
            raise SdfpbrError("a render worker died (killed, or out of memory); rerun the build") from None
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise


def _write_output(out: Path, item: Item, data: bytes) -> None:
    path = out / f"{item.name}.png"
    try:
        if path.read_bytes() == data:
            return                      # already there: keep the file (and its mtime)
    except OSError:
        pass
    _write_atomic(path, data, "output")


def _previous_images(out: Path) -> set[str]:
    """Images the last build into ``out`` wrote, from its manifest (plain names only)."""
    try:
        manifest = json.loads((out / "manifest.json").read_text())
        names = {entry["image"] for entry in manifest["images"]}
    except (OSError, ValueError, KeyError, TypeError):
        return set()
    return {n for n in names if isinstance(n, str) and n.endswith(".png") and "/" not in n
            and "\\" not in n and not n.startswith(".")}


def _png_size(data: bytes) -> tuple[int, int]:
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def _manifest(items, results, renderers, chart_dir, elapsed) -> dict:
    images = []
    for item in items:
        r = results[item.name]
        w, h = _png_size(r.png)
        images.append({
            "image": f"{item.name}.png",
            "name": item.name,
            "entry": Path(item.entry).name,
            "kind": item.kind,
            "caption": item.caption,
            "params": item.params,
            "key": r.key,
            "cached": r.cached,
            "width": w,
            "height": h,
            "sha256": hashlib.sha256(r.png).hexdigest(),
            "timings": {"render_s": round(r.seconds, 4), **r.timings},
            "specs": [s.to_dict() for s in item.specs],
        })
    return {
        "sdfpbr": __version__,
        "charts": str(chart_dir),
        "gl_renderers": sorted(set(renderers.values())),
        "images": images,
        "rendered": sum(1 for e in images if not e["cached"]),
        "cached": sum(1 for e in images if e["cached"]),
        "elapsed_s": round(elapsed, 3),
    }


# ---------------------------------------------------------------------------------------------
# The static gallery.

def _param_text(value: Any) -> str:
    if isinstance(value, (list, tuple)):
        return ", ".join(_param_text(v) for v in value)
    if isinstance(value, dict):
        return "; ".join(f"{k} = {_param_text(v)}" for k, v in value.items())
    return str(value)


_CSS = """
body { background: #181818; color: #ddd; font: 15px/1.4 system-ui, sans-serif; margin: 2em; }
h1 { font-weight: 500; }
.gallery { display: grid; grid-template-columns: repeat(auto-fill, minmax(340px, 1fr)); gap: 1.5em; }
figure { margin: 0; background: #222; padding: 0.8em; border-radius: 6px; }
figure img { width: 100%; height: auto; display: block; }
figcaption { margin-top: 0.6em; }
dl { display: grid; grid-template-columns: max-content 1fr; gap: 0.1em 0.8em; font-size: 13px; color: #aaa; }
dt { color: #888; } dd { margin: 0; word-break: break-word; }
.name { font-family: monospace; color: #9cf; }
details { font-size: 12px; color: #999; } pre { white-space: pre-wrap; }
"""


def gallery_html(manifest: dict) -> str:
    """A static page: every image with its caption and parameters; all text escaped."""
    e = html.escape
    figures = []
    for image in manifest["images"]:
        params = "".join(
            f"<dt>{e(str(k))}</dt><dd>{e(_param_text(v))}</dd>"
            for k, v in image["params"].items() if v not in ({}, [], "")
        )
        specs = e(json.dumps(image["specs"], indent=1, ensure_ascii=False))
        src = e(quote(image["image"]))
        figures.append(
            f'<figure id="{e(image["name"])}">\n'
            f'  <a href="{src}"><img src="{src}" loading="lazy" width="{image["width"]}" height="{image["height"]}" '
            f'alt="{e(image["caption"] or image["name"])}"></a>\n'
            f'  <figcaption><span class="name">{e(image["name"])}</span> '
            f'<small>({e(image["entry"])}, {e(image["kind"])})</small><br>{e(image["caption"])}\n'
            f'    <dl>{params}</dl>\n'
            f'    <details><summary>specs</summary><pre>{specs}</pre></details></figcaption>\n'
            f'</figure>'
        )
    renderers = e(", ".join(manifest["gl_renderers"]))
    return (
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
        f"<title>sdfpbr gallery</title>\n<style>{_CSS}</style>\n</head>\n<body>\n"
        f"<h1>sdfpbr gallery</h1>\n<p>{len(manifest['images'])} images from {e(manifest['charts'])}, "
        f"sdfpbr {e(manifest['sdfpbr'])}, rendered with {renderers}.</p>\n"
        f"<div class=\"gallery\">\n" + "\n".join(figures) + "\n</div>\n</body>\n</html>\n"
    )


def main_progress(line: str) -> None:
    print(line, file=sys.stderr, flush=True)
