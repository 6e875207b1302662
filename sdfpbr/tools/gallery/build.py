"""The build: every item through the image cache (rendering the missing ones, in worker
processes with -j), then the images, ``manifest.json`` and ``index.html`` in the output
directory; the main process alone writes files."""
from __future__ import annotations

import hashlib
import json
import os
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from ... import __version__
from ...errors import OutputError, SdfpbrError, SpecError
from ...files import remove_stale_temps
from .entries import Item, collect
from .images import ImageCache, Rendered, checkpoint, render_item, write_file
from .keys import gl_renderers, item_keys
from .page import gallery_html


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


def build(chart_dir: str | Path, out_dir: str | Path, jobs: int = 1, force: bool = False,
          log: Callable[[str], None] | None = None, verbose: bool = False) -> dict:
    """Build the gallery of ``chart_dir`` into ``out_dir``; returns the manifest. ``log`` gets
    one line per image ("[3/12] name.png  rendered in 0.41 s") and warnings."""
    start = time.perf_counter()
    say = log or (lambda line: None)
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
    cache = ImageCache()
    keys = item_keys(items, renderers, cache.dir / "keys.json")
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
        checkpoint("render")
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
    write_file(out / "manifest.json", (json.dumps(manifest, indent=2, ensure_ascii=False) + "\n").encode(), "manifest")
    write_file(out / "index.html", gallery_html(manifest).encode(), "index")
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
