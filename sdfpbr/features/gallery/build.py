"""The build: every item through the image cache (rendering the missing ones, in worker
processes with -j), then the images, ``manifest.json`` and ``index.html`` in the output
directory; the main process alone writes files.

A large gallery shards across machines: ``build(..., shard=(i, n))`` renders every n-th item
(from the i-th, in entry order) into its own directory with a partial manifest, and ``merge``
joins the shards' directories into the gallery (images checked against their manifests'
hashes, no GL needed) — a CI matrix runs the shards, a last job the merge.

What a build reads and deletes:

* The entries, and every file they name, lie inside the entries folder (or the ``root`` given):
  entries.py confines them; a path that leads out is refused in one line.
* Every manifest (the output folder's own, a shard's) is read through sdfpbr.inputs.read_json:
  a regular file of bounded size and nesting, a one-line error otherwise.
* The manifests a build writes say ``"generator": "sdfpbr"``. A build deletes an image the
  last build wrote and no entry makes any more only when the output folder's manifest is
  one of those, every image it lists is a plain ``<name>.png`` (no '/', '\\', leading '.')
  directly in the folder with a sha256 key, and the file is a regular one carrying that key in
  its PNG metadata (an image sdfpbr rendered). A foreign or malformed manifest deletes
  nothing; the build writes its own over it."""
from __future__ import annotations

import hashlib
import json
import os
import stat
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from ... import __version__
from ...cache import HEX_KEY, claim, remove_stale_temporaries, touch
from ...errors import OutputError, SdfpbrError, SpecError
from ...files import remove_stale_temps
from ...inputs import parse_json, read_input, read_json
from ...progress import Ticker
from ...workers import cores, process_pool
from .images import ImageCache, Rendered, checkpoint, png_key, prepare_helpers, render_items, write_file
from .page import gallery_html
from .stamp import InputLog, package_files, record, stamp_path, unchanged

if TYPE_CHECKING:     # the entries, their specs and keys (numpy, the glTF parser, GL) load only
    from .entries import Item    # when a build is not answered by its stamp (stamp.py)

GENERATOR = "sdfpbr"      # the "generator" of every manifest a build or a merge writes


def _worker(items: list[Item], keys: list[str]) -> list[Rendered]:
    from ...shading.compose import modules_fixed
    rendered: dict[str, Rendered] = {}
    with modules_fixed():
        render_items(items, {item.name: key for item, key in zip(items, keys)},
                     lambda item, result: rendered.__setitem__(item.name, result))
    return [rendered[item.name] for item in items]


def work_groups(items: list[Item]) -> list[list[Item]]:
    """The items a parallel build gives one worker at a time: those that render a spec in
    common go together (in entry order), so that the renders and FLIP maps one keeps serve the
    others. Apart, the bug catalog and the bug comparisons that share its charts were each
    rendered in a worker of their own, and the catalog ran alone at the end for twice its time.
    Largest groups (by specs) first: the longest work starts first."""
    from .entries import spec_identity
    parent = list(range(len(items)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    first: dict[str, int] = {}       # a spec's text -> the first item that renders it
    for i, item in enumerate(items):
        for spec in item.specs:
            parent[root(i)] = root(first.setdefault(spec_identity(spec), i))
    groups: dict[int, list[Item]] = {}
    for i, item in enumerate(items):
        groups.setdefault(root(i), []).append(item)
    return sorted(groups.values(), key=lambda group: -sum(len(item.specs) for item in group))


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


def progress_line(done: int, total: int, image: str, what: str, key: str = "") -> str:
    """"[ 3/12] name.png  rendered in 0.41 s", with the key's first 12 digits when given."""
    return f"[{done:{len(str(total))}d}/{total}] {image}  {what}" + (f"  {key[:12]}" if key else "")


def check_shard(shard) -> tuple[int, int] | None:
    """(i, n) with 1 <= i <= n, or None."""
    if shard is None:
        return None
    ok = isinstance(shard, tuple) and len(shard) == 2 and all(isinstance(v, int) and not isinstance(v, bool)
                                                              for v in shard)
    if not ok or not 1 <= shard[0] <= shard[1]:
        raise SpecError(f"shard must be I/N with 1 <= I <= N, got {shard!r}")
    return shard


def shard_items(items: list[Item], shard: tuple[int, int] | None) -> list[Item]:
    """The items shard (i, n) renders: every n-th in entry order, from the i-th."""
    if shard is None:
        return items
    i, n = shard
    return items[i - 1::n]


def _check_out(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise OutputError(f"output {out} exists and is not a directory")
    if not out.exists() and not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise OutputError(f"cannot create output directory {out}: {out.parent} does not exist")


def _make_out(out: Path) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create output directory {out}: {exc.strerror or exc}") from None
    remove_stale_temps(out)


def build(chart_dir: str | Path, out_dir: str | Path, jobs: int = 1, force: bool = False,
          log: Callable[[str], None] | None = None, verbose: bool = False,
          shard: tuple[int, int] | None = None, root: str | Path | None = None) -> dict:
    """Build the gallery of ``chart_dir`` into ``out_dir``; returns the manifest. ``log`` gets
    one line per image ("[3/12] name.png  rendered in 0.41 s") and warnings. With ``shard``
    (i, n): only that shard's images and a partial manifest (no index.html); see merge. The
    entries read only files inside ``root`` (default: ``chart_dir``; entries.collect)."""
    start = time.perf_counter()
    say = log or (lambda line: None)
    shard = check_shard(shard)
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 0:
        raise SpecError(f"-j must be a whole number >= 0 (0: one per CPU), got {jobs!r}")
    jobs = jobs or cores()
    out = Path(out_dir)
    cache = ImageCache()
    stamp_file = stamp_path(cache.dir, chart_dir, out, shard, root)
    if not force:
        manifest = _replay(stamp_file, cache, chart_dir, out, shard, say, verbose, start)
        if manifest is not None:
            return manifest
    from ...shading.compose import modules_fixed
    with modules_fixed():   # the build's keys and renders read one version of each shader module
        return _full_build(chart_dir, out, force, jobs, say, verbose, shard, start, cache, stamp_file, root)


def _full_build(chart_dir, out: Path, force: bool, jobs: int, say, verbose: bool, shard, start: float,
                cache: ImageCache, stamp_file: Path, root=None) -> dict:
    from .entries import collect
    from .keys import gl_renderers, item_keys
    packages = package_files()
    with InputLog(cache.root) as inputs:
        items = shard_items(collect(chart_dir, root), shard)   # every entry validated before any output
        _check_out(out)
        if jobs <= 1:
            prepare_helpers(items)
        renderers = gl_renderers(items)
        try:
            claim(cache.root)   # the cache's marker before its first write (sdfpbr.cache)
        except OSError:
            pass                # an unwritable cache only costs speed
        keys = item_keys(items, renderers, cache.dir / "keys.json")
    remove_stale_temporaries(cache.root)
    _make_out(out)
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
        say(progress_line(len(results), total, f"{item.name}.png", "cached", keys[item.name] if verbose else ""))

    uncached = []     # images a later build cannot find in the cache: no stamp then

    def done(item: Item, rendered: Rendered) -> None:
        key = keys[item.name]
        checkpoint("render")
        if rendered.renderer and rendered.renderer not in renderers.values():
            # Rendered on another GL than the key says: use the image, but do not cache it.
            say(f"warning: {item.name} rendered on {rendered.renderer}, not caching it")
            uncached.append(item.name)
        elif not cache.put(key, rendered.png):
            uncached.append(item.name)
        results[item.name] = Result(item, key, False, rendered.png, rendered.seconds, rendered.timings)
        say(progress_line(len(results), total, f"{item.name}.png", f"rendered in {rendered.seconds:.2f} s",
                          key if verbose else ""))
        still.restart()

    groups = work_groups(todo)
    workers = min(jobs, len(groups))
    # A line every few seconds while an image takes long (the catalog's: minutes on a CPU).
    with Ticker("[...] still drawing", enabled=bool(todo), say=say, end=False) as still:
        if workers <= 1:
            render_items(todo, keys, done)
        else:
            _render_parallel(groups, keys, workers, done)

    # The images go in only when every entry has rendered: an entry that fails (a file it names
    # turned out unreadable) leaves the folder as the last build left it, images and manifest
    # alike. (A kill between these writes leaves some new images under the old manifest; the
    # next build writes the rest, as after a kill anywhere.)
    for item in items:
        _write_output(out, item, results[item.name].png)
    manifest = _manifest(items, results, renderers, chart_dir, time.perf_counter() - start)
    if shard is not None:
        manifest["shard"] = list(shard)
    _finish(out, manifest, previous, page=shard is None)
    if not uncached:
        record(stamp_file, inputs, packages, _as_unchanged(manifest))
    return manifest


def _as_unchanged(manifest: dict) -> dict:
    """The manifest a build with nothing to render writes after this one."""
    images = [{**image, "cached": True, "timings": {"render_s": 0.0}} for image in manifest["images"]]
    return {**manifest, "images": images, "rendered": 0, "cached": len(images)}


def _replay(stamp_file: Path, cache: ImageCache, chart_dir, out: Path, shard, say, verbose: bool,
            start: float) -> dict | None:
    """The build as its stamp recorded it, if no input changed, the output directory still
    holds the recorded images byte for byte and the cache every one of them; else None."""
    recorded, why = unchanged(stamp_file)
    if recorded is None:
        if verbose:
            say(f"full build: {why}")
        return None
    try:
        images = recorded["images"]
        written = read_json(out / "manifest.json", "manifest")
        if written.get("generator") != GENERATOR:
            raise ValueError
        written = written["images"]
        if [(e["image"], e["sha256"]) for e in written] != [(e["image"], e["sha256"]) for e in images]:
            raise ValueError
        for image in images:
            if not plain_image(image["image"]):
                raise ValueError
            data = read_input(out / image["image"], "image", "image")
            if hashlib.sha256(data).hexdigest() != image["sha256"] or \
                    read_input(cache.path(image["key"]), "cache entry", "image") != data:
                raise ValueError
    except (SpecError, OSError, ValueError, KeyError, TypeError, AttributeError):
        if verbose:
            say(f"full build: {out} or the cache does not hold the last build's images")
        return None
    _make_out(out)
    cache.remove_stale_temps()
    total = len(images)
    for i, image in enumerate(images, start=1):
        touch(cache.path(image["key"]))        # used now, as a cache hit marks it
        say(progress_line(i, total, image["image"], "cached", image["key"] if verbose else ""))
    manifest = {**recorded, "charts": str(chart_dir), "elapsed_s": round(time.perf_counter() - start, 3)}
    _finish(out, manifest, {}, page=shard is None)
    return manifest


def manifest_text(manifest: dict) -> str:
    """The manifest as JSON, a line per key and per image: each line through json's C encoder
    (``indent`` takes the pure-Python one, 0.08 s of a 0.5 s build with nothing to render)."""
    def line(value):
        return json.dumps(value, ensure_ascii=False)
    def value(key, v):
        if key != "images" or not v:
            return line(v)
        return "[\n" + ",\n".join(f"    {line(image)}" for image in v) + "\n  ]"
    return "{\n" + ",\n".join(f"  {line(k)}: {value(k, v)}" for k, v in manifest.items()) + "\n}\n"


def _finish(out: Path, manifest: dict, previous: dict[str, str], page: bool) -> None:
    """The manifest (and the page) last, then the images of entries that no longer exist go:
    those the last build's own manifest listed (``previous``: name -> key, _previous_images),
    each only if it still is the image sdfpbr wrote (_remove_own_image)."""
    write_file(out / "manifest.json", manifest_text(manifest).encode(), "manifest")
    if page:
        write_file(out / "index.html", gallery_html(manifest).encode(), "index")
    for name in sorted(set(previous) - {entry["image"] for entry in manifest["images"]}):
        _remove_own_image(out / name, previous[name])   # an image of an entry that no longer exists


def _remove_own_image(path: Path, key: str) -> bool:
    """Delete ``path`` if it is a regular file (not a symlink) holding a PNG that carries the
    build key ``key``: an image sdfpbr rendered, not a file that took its name."""
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode):
            return False
        if png_key(read_input(path, "image", "image")) != key:
            return False
        path.unlink()
        return True
    except (OSError, SpecError):
        return False


# What each image record of a manifest holds (_manifest), as merge checks a shard's.
RECORD_FIELDS = {"image": str, "name": str, "entry": str, "kind": str, "caption": str, "params": dict,
                 "key": str, "cached": bool, "width": int, "height": int, "sha256": str, "timings": dict,
                 "specs": list}


def _shard_manifest(part: Path) -> tuple[list[dict], list[str]]:
    """(image records, GL renderers) of the manifest a shard build wrote in ``part``, read
    through sdfpbr.inputs (bounded size and nesting); a one-line SpecError otherwise."""
    why = None
    try:
        manifest = parse_json(read_input(part / "manifest.json", "its manifest", "manifest"), "manifest.json")
    except SpecError as exc:
        detail = str(exc)
        if detail.startswith("manifest.json: "):      # parse_json's: the text is not what JSON reads
            detail = detail[len("manifest.json: "):]
            why = "it is not JSON" if detail.startswith("malformed JSON") else f"its {detail}"
        else:                                         # read_input's: missing, a FIFO, too large
            why = detail
    else:
        entries = manifest.get("images") if isinstance(manifest, dict) else None
        shard_renderers = manifest.get("gl_renderers", []) if isinstance(manifest, dict) else None
        if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
            why = "it is not a table with a list of images"
        elif not isinstance(shard_renderers, list) or not all(isinstance(r, str) for r in shard_renderers):
            why = "its gl_renderers is not a list of names"
        elif manifest.get("generator") != GENERATOR:
            why = f'sdfpbr did not write it (no "generator": "{GENERATOR}")'
    if why is not None:
        raise SpecError(f"{part} holds no readable manifest.json of a build shard: {why} "
                        f"(give the directories `sdfpbr build --shard i/n` wrote)")
    return entries, shard_renderers


def _check_record(part: Path, entry: dict, names: set[str], chart_dir) -> str:
    """The entry name of a shard's image record, checked: an image of an entry in
    ``chart_dir``, named <name>.png, every field of its kind (what the page reads)."""
    name = entry.get("name")
    if not isinstance(name, str) or name not in names:
        shown = repr(name) if len(repr(name)) <= 80 else repr(name)[:77] + "..."
        raise SpecError(f"{part}: its manifest lists {shown}, the image of no entry in {chart_dir}; "
                        f"build the shards from the same chart directory")
    for key, kind in RECORD_FIELDS.items():
        value = entry.get(key)
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            raise SpecError(f"{part}: its manifest's record of {name}.png has no {key} "
                            f"({kind.__name__}); give the directories `sdfpbr build --shard i/n` wrote")
    if entry["image"] != f"{name}.png" or not HEX_KEY.fullmatch(entry["key"]):
        raise SpecError(f"{part}: its manifest's record of {name}.png names another image or no key")
    return name


def merge(chart_dir: str | Path, parts: list[str | Path], out_dir: str | Path,
          log: Callable[[str], None] | None = None, root: str | Path | None = None) -> dict:
    """Join shard directories (each written by build(..., shard=...)) into the gallery of
    ``chart_dir`` in ``out_dir``: every entry's image must be in exactly one part, with the
    bytes its manifest's sha256 names; the merged manifest and index.html list them in entry
    order. Nothing renders and no GL is needed. A shard's manifest must be one a build wrote
    ("generator"), its records those of the gallery's entries."""
    from .entries import collect
    start = time.perf_counter()
    say = log or (lambda line: None)
    items = collect(chart_dir, root)
    out = Path(out_dir)
    _check_out(out)
    found: dict[str, tuple[dict, bytes, Path]] = {}
    renderers: set[str] = set()
    wanted = {item.name for item in items}
    for part in map(Path, parts):
        entries, shard_renderers = _shard_manifest(part)
        renderers.update(shard_renderers)
        for entry in entries:
            name = _check_record(part, entry, wanted, chart_dir)
            if name in found:
                raise SpecError(f"{entry.get('image')} is in both {found[name][2]} and {part}")
            if not os.path.lexists(part / f"{name}.png"):
                raise SpecError(f"{part}: {name}.png, listed in its manifest, is missing")
            data = read_input(part / f"{name}.png", "shard image", "image")
            if hashlib.sha256(data).hexdigest() != entry.get("sha256"):
                raise SpecError(f"{part}: {name}.png is not the image its manifest names (sha256 differs)")
            found[name] = (entry, data, part)
    names = [item.name for item in items]
    missing = [n for n in names if n not in found]
    if missing:
        raise SpecError(f"no shard holds {len(missing)} of the gallery's images: {', '.join(missing[:5])}"
                        f"{' ...' if len(missing) > 5 else ''}; merge every shard's directory")
    extra = sorted(set(found) - set(names))
    if extra:
        raise SpecError(f"the shards hold images of no entry in {chart_dir}: {', '.join(extra[:5])}; "
                        f"build the shards from the same chart directory")
    _make_out(out)
    previous = _previous_images(out)
    for i, item in enumerate(items, start=1):
        _write_output(out, item, found[item.name][1])
        say(progress_line(i, len(items), f"{item.name}.png", f"from {found[item.name][2]}"))
    images = [found[n][0] for n in names]
    manifest = {
        "generator": GENERATOR,
        "sdfpbr": __version__,
        "charts": str(chart_dir),
        "gl_renderers": sorted(renderers),
        "images": images,
        "rendered": sum(1 for e in images if not e.get("cached")),
        "cached": sum(1 for e in images if e.get("cached")),
        "shards": len(parts),
        "elapsed_s": round(time.perf_counter() - start, 3),
    }
    _finish(out, manifest, previous, page=True)
    return manifest


def _render_parallel(groups: list[list[Item]], keys: dict, workers: int, done) -> None:
    from concurrent.futures import FIRST_COMPLETED, wait
    from concurrent.futures.process import BrokenProcessPool
    with process_pool(workers) as pool:
        futures = {pool.submit(_worker, group, [keys[item.name] for item in group]): group for group in groups}
        pending = set(futures)
        try:
            while pending:
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in finished:
                    for item, rendered in zip(futures[future], future.result()):
                        done(item, rendered)
        except BrokenProcessPool:
            raise SdfpbrError("a render worker died (killed, or out of memory); rerun the build") from None
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise


def _write_output(out: Path, item: Item, data: bytes) -> None:
    path = out / f"{item.name}.png"
    try:   # a regular file only: a FIFO under the image's name would hang a plain read
        if read_input(path, "image", "image") == data:
            return                      # already there: keep the file (and its mtime)
    except SpecError:
        pass
    write_file(path, data, "output")


def plain_image(name) -> bool:
    """Whether ``name`` is an image name a build writes: ``<name>.png`` directly in the output
    folder (no '/', '\\', NUL, leading '.', hence no '..')."""
    return (isinstance(name, str) and name.endswith(".png") and len(name) > len(".png") and not name.startswith(".")
            and not any(c in name for c in "/\\\0") and len(name.encode(errors="replace")) <= 255)


def _previous_images(out: Path) -> dict[str, str]:
    """Images the last build into ``out`` wrote (name -> build key), from its manifest: only a
    manifest sdfpbr wrote ("generator") whose every record names a plain image
    (``plain_image``, ``<name>.png`` of its entry name) with a sha256 key. A manifest that is
    missing, unreadable (a FIFO, too large, too deep), malformed or foreign gives none, so
    nothing is deleted."""
    try:
        manifest = read_json(out / "manifest.json", "manifest")
    except SpecError:
        return {}
    if not isinstance(manifest, dict) or manifest.get("generator") != GENERATOR \
            or not isinstance(manifest.get("images"), list):
        return {}
    previous = {}
    for entry in manifest["images"]:
        image = entry.get("image") if isinstance(entry, dict) else None
        name, key = (entry.get("name"), entry.get("key")) if isinstance(entry, dict) else (None, None)
        if not (plain_image(image) and isinstance(name, str) and image == f"{name}.png"
                and isinstance(key, str) and HEX_KEY.fullmatch(key)):
            return {}          # one record not as a build writes it: the manifest is not trusted
        previous[image] = key
    return previous


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
        "generator": GENERATOR,
        "sdfpbr": __version__,
        "charts": str(chart_dir),
        "gl_renderers": sorted(set(renderers.values())),
        "images": images,
        "rendered": sum(1 for e in images if not e["cached"]),
        "cached": sum(1 for e in images if e["cached"]),
        "elapsed_s": round(elapsed, 3),
    }
