"""The build: every item through the image cache (rendering the missing ones, in worker
processes with -j), then the images, ``manifest.json`` and ``index.html`` in the output
directory; the main process alone writes files.

A large gallery shards across machines: ``build(..., shard=(i, n))`` renders every n-th item
(from the i-th, in entry order) into its own directory with a partial manifest, and ``merge``
joins the shards' directories into the gallery (images checked against their manifests'
hashes, no GL needed) — a CI matrix runs the shards, a last job the merge."""
from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from ... import __version__
from ...cache import remove_stale_temporaries, touch
from ...errors import OutputError, SdfpbrError, SpecError
from ...files import remove_stale_temps
from ...workers import cores, process_pool
from .images import ImageCache, Rendered, checkpoint, prepare_helpers, render_items, write_file
from .page import gallery_html
from .stamp import InputLog, package_files, record, stamp_path, unchanged

if TYPE_CHECKING:     # the entries, their specs and keys (numpy, the glTF parser, GL) load only
    from .entries import Item    # when a build is not answered by its stamp (stamp.py)


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
          shard: tuple[int, int] | None = None) -> dict:
    """Build the gallery of ``chart_dir`` into ``out_dir``; returns the manifest. ``log`` gets
    one line per image ("[3/12] name.png  rendered in 0.41 s") and warnings. With ``shard``
    (i, n): only that shard's images and a partial manifest (no index.html); see merge."""
    start = time.perf_counter()
    say = log or (lambda line: None)
    shard = check_shard(shard)
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 0:
        raise SpecError(f"-j must be a whole number >= 0 (0: one per CPU), got {jobs!r}")
    jobs = jobs or cores()
    out = Path(out_dir)
    cache = ImageCache()
    stamp_file = stamp_path(cache.dir, chart_dir, out, shard)
    if not force:
        manifest = _replay(stamp_file, cache, chart_dir, out, shard, say, verbose, start)
        if manifest is not None:
            return manifest
    from ...shading.compose import modules_fixed
    with modules_fixed():   # the build's keys and renders read one version of each shader module
        return _full_build(chart_dir, out, force, jobs, say, verbose, shard, start, cache, stamp_file)


def _full_build(chart_dir, out: Path, force: bool, jobs: int, say, verbose: bool, shard, start: float,
                cache: ImageCache, stamp_file: Path) -> dict:
    from .entries import collect
    from .keys import gl_renderers, item_keys
    packages = package_files()
    with InputLog(cache.root) as inputs:
        items = shard_items(collect(chart_dir), shard)   # every entry validated before any output
        _check_out(out)
        if jobs <= 1:
            prepare_helpers(items)
        renderers = gl_renderers(items)
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

    groups = work_groups(todo)
    workers = min(jobs, len(groups))
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
    images = recorded["images"]
    try:
        written = json.loads((out / "manifest.json").read_text())["images"]
        if [(e["image"], e["sha256"]) for e in written] != [(e["image"], e["sha256"]) for e in images]:
            raise ValueError
        for image in images:
            data = (out / image["image"]).read_bytes()
            if hashlib.sha256(data).hexdigest() != image["sha256"] or cache.path(image["key"]).read_bytes() != data:
                raise ValueError
    except (OSError, ValueError, KeyError, TypeError):
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
    _finish(out, manifest, set(), page=shard is None)
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


def _finish(out: Path, manifest: dict, previous: set[str], page: bool) -> None:
    """The manifest (and the page) last, then the images of entries that no longer exist go."""
    write_file(out / "manifest.json", manifest_text(manifest).encode(), "manifest")
    if page:
        write_file(out / "index.html", gallery_html(manifest).encode(), "index")
    for name in previous - {entry["image"] for entry in manifest["images"]}:
        try:
            (out / name).unlink()     # an image of an entry that no longer exists
        except OSError:
            pass


def merge(chart_dir: str | Path, parts: list[str | Path], out_dir: str | Path,
          log: Callable[[str], None] | None = None) -> dict:
    """Join shard directories (each written by build(..., shard=...)) into the gallery of
    ``chart_dir`` in ``out_dir``: every entry's image must be in exactly one part, with the
    bytes its manifest's sha256 names; the merged manifest and index.html list them in entry
    order. Nothing renders and no GL is needed."""
    from .entries import collect
    start = time.perf_counter()
    say = log or (lambda line: None)
    items = collect(chart_dir)
    out = Path(out_dir)
    _check_out(out)
    found: dict[str, tuple[dict, bytes, Path]] = {}
    renderers: set[str] = set()
    for part in map(Path, parts):
        why = None
        try:
            manifest = json.loads((part / "manifest.json").read_text())
        except OSError as exc:
            why = exc.strerror or str(exc)
        except ValueError:
            why = "it is not JSON"
        else:
            entries = manifest.get("images") if isinstance(manifest, dict) else None
            shard_renderers = manifest.get("gl_renderers", []) if isinstance(manifest, dict) else None
            if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
                why = "it is not a table with a list of images"
            elif not isinstance(shard_renderers, list) or not all(isinstance(r, str) for r in shard_renderers):
                why = "its gl_renderers is not a list of names"
        if why is not None:
            raise SpecError(f"{part} holds no readable manifest.json of a build shard: {why} "
                            f"(give the directories `sdfpbr build --shard i/n` wrote)")
        renderers.update(shard_renderers)
        for entry in entries:
            name = entry.get("name")
            if name in found:
                raise SpecError(f"{entry.get('image')} is in both {found[name][2]} and {part}")
            try:
                data = (part / f"{name}.png").read_bytes()
            except (OSError, TypeError):
                raise SpecError(f"{part}: {name}.png, listed in its manifest, is missing") from None
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
    try:
        if path.read_bytes() == data:
            return                      # already there: keep the file (and its mtime)
    except OSError:
        pass
    write_file(path, data, "output")


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
