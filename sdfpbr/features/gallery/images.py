"""Images by key: the verified on-disk cache, rendering one item into PNG bytes that carry its
key, and the kill-point test hook every build write passes through."""
from __future__ import annotations

import hashlib
import os
import zlib
import signal
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from ...cache import HEX_KEY, after_write, cache_max, claim, default_cache_dir, remove_stale_temporaries, touch
from ...errors import OutputError, SpecError
from ...files import write_bytes
from ...inputs import read_input
from ...progress import Ticker

if TYPE_CHECKING:     # the cache and the writes load without the specs (a build answered by its stamp)
    from ...spec.chart_spec import ChartSpec
    from .entries import Item

KEY_FIELD = "sdfpbr:build-key"
ENTRY_FIELD = "sdfpbr:gallery-entry"
KILL_ENV = "SDFPBR_BUILD_KILL_AT"           # test hook, "phase:n", see checkpoint

_hits: Counter = Counter()


def checkpoint(phase: str) -> None:
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


def write_file(path: Path, data: bytes, phase: str, durable: bool = True) -> None:
    """An atomic write (sdfpbr.files) with the kill points ``phase``-temp (written, not yet
    renamed) and ``phase`` (in place)."""
    write_bytes(path, data, before_rename=lambda: checkpoint(phase + "-temp"), durable=durable)
    checkpoint(phase)


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_key(data: bytes) -> str | None:
    """The build key stored in a PNG, or None if the bytes are not a complete, intact PNG: every
    chunk's CRC-32 must match and the file must end in IEND, which catches a truncated file or
    a flipped byte anywhere without decoding the pixels (decoding cost 14 ms an image, most of
    a no-change gallery build)."""
    if not data.startswith(PNG_SIGNATURE):
        return None
    key, pos, end = None, len(PNG_SIGNATURE), len(data)
    while pos + 12 <= end:
        length = int.from_bytes(data[pos:pos + 4], "big")
        kind = data[pos + 4:pos + 8]
        body_end = pos + 8 + length
        if (body_end + 4 > end
                or zlib.crc32(data[pos + 4:body_end]) != int.from_bytes(data[body_end:body_end + 4], "big")):
            return None
        if kind == b"iTXt":
            keyword, _, rest = data[pos + 8:body_end].partition(b"\0")
            if keyword == KEY_FIELD.encode() and len(rest) >= 2:
                compressed, text = rest[0], rest[2:].split(b"\0", 2)[-1]   # after language and translated keyword
                try:
                    key = (zlib.decompress(text) if compressed else text).decode()
                except (zlib.error, UnicodeDecodeError):
                    return None
        pos = body_end + 4
        if kind == b"IEND":
            return key if pos == end else None
    return None


class ImageCache:
    """Rendered images by key in ``<root>/build``; an entry is used only if it verifies. The
    root is sdfpbr's cache (sdfpbr.cache: marked, and only entries named as sdfpbr names them
    are ever counted or deleted)."""

    def __init__(self, root: str | Path | None = None):
        self.root = Path(root or default_cache_dir())
        self.dir = self.root / "build"
        cache_max()   # a malformed $SDFPBR_CACHE_MAX is refused before any work

    def path(self, key: str) -> Path:
        """``<root>/build/<key>.png`` (a key that is no sha256 hex digest, which sdfpbr never
        makes, is named by its sha256: the cache's naming, sdfpbr.cache)."""
        name = key if HEX_KEY.fullmatch(key) else hashlib.sha256(key.encode()).hexdigest()
        return self.dir / f"{name}.png"

    def get(self, key: str) -> bytes | None:
        try:   # a regular file within an image's size (a FIFO put there would hang a plain read)
            data = read_input(self.path(key), "cache entry", "image")
        except SpecError:
            return None
        if png_key(data) != key:
            return None
        touch(self.path(key))
        return data

    def put(self, key: str, data: bytes) -> bool:
        """Best effort: an unwritable cache only costs speed."""
        try:
            claim(self.root)
            self.dir.mkdir(parents=True, exist_ok=True)
            write_file(self.path(key), data, "cache", durable=False)   # get() verifies its chunks and key
            after_write(self.root, len(data))
            return True
        except (OSError, OutputError):
            return False

    def remove_stale_temps(self) -> int:
        return remove_stale_temporaries(self.root, "build")


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
    from ...image.io import png_bytes
    start = time.perf_counter()
    timings = {}
    if item.kind == "chart":
        from ...api import chart
        result = chart(item.specs[0])
        image, metadata, renderer = result.image, result.metadata(), result.renderer
        timings = {k: round(v, 4) for k, v in result.result.timings.items()}
    else:
        from .. import compare
        if item.kind == "compare":
            sheet = compare.compare_bug(item.base, item.bug)
        elif item.kind == "bug-sheet":
            # Measured at the base's own size: the entry's [spec] decides the figures.
            sheet = compare.bug_catalog(item.base, list(item.bug_names), measure_size=None, pages=[item.page])[0]
        elif item.kind == "compare-specs":
            sheet = compare.compare_specs(item.specs[0], item.specs[1], labels=item.labels, caption=item.caption)
        else:
            sheet = compare.sweep(item.base, item.sweep_field, list(item.sweep_values))
        image, metadata, renderer = sheet.image, sheet.metadata(), sheet.renderer
    metadata = {**metadata, KEY_FIELD: key, ENTRY_FIELD: item.canonical}
    data = png_bytes(image, metadata)
    return Rendered(data, time.perf_counter() - start, renderer, timings)


def flip_pairs(item: Item) -> list[tuple[ChartSpec, str]]:
    """The (base, bug) pairs whose FLIP ``item`` measures (bug comparisons and the catalog)."""
    if item.kind == "compare":
        return [(item.base, item.bug)]
    if item.kind == "bug-sheet":
        from ..compare import catalog_pages
        return [(item.base, name) for name in catalog_pages(item.bug_names)[item.page - 1]]
    return []


def render_items(items: list[Item], keys: dict[str, str], done: Callable[[Item, Rendered], None]) -> None:
    """Render ``items`` on this process's GL context, calling ``done`` with each (in order of
    completion). The pairs the comparisons measure are rendered first; where worker processes
    can start (sheet_pool), each comparison is handed to one with its renders as soon as they
    are made and composed there (its FLIP measured, its page laid out and encoded) while this
    process goes on drawing, the catalog last; else their FLIPs alone go to workers
    (metrics.FlipBatch) and the pages are composed here. Composed here, the bug pages and the
    catalog were the last third of a gallery build, on one core."""
    pairs = list(dict.fromkeys(pair for item in items for pair in flip_pairs(item)))
    measuring = sorted((item for item in items if flip_pairs(item)), key=lambda item: len(flip_pairs(item)))
    others = [item for item in items if not flip_pairs(item)]
    if not pairs:
        for item in items:
            done(item, render_item(item, keys[item.name]))
        return
    with sheet_pool(measuring) as pool:
        if pool is not None:
            _compose_in_workers(measuring, others, keys, done, pool)
            return
    from ...image.metrics import FlipBatch
    from ..compare import submit_bug_pairs
    with FlipBatch(len(pairs)) as batch:
        start = time.perf_counter()
        for base, name in pairs:
            submit_bug_pairs(base, [name], batch)
        share = (time.perf_counter() - start) / len(measuring)   # each measuring item's part of it
        for item in others:
            done(item, render_item(item, keys[item.name]))
        for item in measuring:   # fewest pairs first: a page takes its FLIP while the rest are measured
            rendered = render_item(item, keys[item.name])
            rendered.seconds += share
            done(item, rendered)


def sheet_pool(items: list[Item]):
    """A workers.helper_pool for the comparisons among ``items`` (None where they are composed
    here)."""
    from ...workers import helper_pool
    from ..compare import HELPER_IMPORTS
    return helper_pool(_comparisons(items), HELPER_IMPORTS)


def prepare_helpers(items: list[Item]) -> None:
    """Start the server the comparisons' helpers fork from, if ``items`` will have helpers: its
    imports then run on a core that is idle while the build makes its keys. (Spawning the
    helpers themselves that early made a cold build no faster, and a build with one plain chart
    paid 0.4 s for workers it did not use: here nothing starts without comparisons to make.)"""
    from ...workers import helpers, start_helper_server
    if helpers(_comparisons(items)):
        from ..compare import HELPER_IMPORTS
        start_helper_server(HELPER_IMPORTS)


def _comparisons(items: list[Item]) -> int:
    return sum(1 for item in items if flip_pairs(item))


def _compose_sheet(item: Item, key: str, renders: list) -> Rendered:
    """A worker's part (module level, for the pool): ``item`` composed from renders made in
    the parent; every FLIP is measured here (the parent's pool has the cores)."""
    from ...shading.compose import modules_fixed
    from ..compare import keep_renders
    start = time.perf_counter()
    keep_renders(renders)
    with modules_fixed():
        rendered = render_item(item, key)
    rendered.seconds = time.perf_counter() - start
    return rendered


def _compose_in_workers(measuring: list[Item], others: list[Item], keys: dict[str, str],
                        done: Callable[[Item, Rendered], None], pool) -> None:
    from concurrent.futures import FIRST_COMPLETED, wait
    from concurrent.futures.process import BrokenProcessPool
    from ..compare import bug_renders
    futures: dict = {}   # future -> (item, the seconds its renders took here)

    def here(item: Item, drawing: float) -> None:   # a worker died (killed, out of memory): compose it here
        rendered = render_item(item, keys[item.name])
        rendered.seconds += drawing
        done(item, rendered)

    def take(finished) -> None:
        for future in finished:
            item, drawing = futures.pop(future)
            try:
                rendered = future.result()
            except BrokenProcessPool:
                here(item, drawing)
                continue
            rendered.seconds += drawing
            done(item, rendered)

    for item in measuring:   # fewest pairs first: the catalog, which needs every pair, last
        start = time.perf_counter()
        pairs = bug_renders(item.base, [name for _, name in flip_pairs(item)])
        renders = list({id(r): r for pair in pairs for r in pair}.values())
        drawing = time.perf_counter() - start
        try:
            futures[pool.submit(_compose_sheet, item, keys[item.name], renders)] = (item, drawing)
        except BrokenProcessPool:
            here(item, drawing)
        take([future for future in futures if future.done()])
    for item in others:   # drawn here while the workers compose
        done(item, render_item(item, keys[item.name]))
        take([future for future in futures if future.done()])
    while futures:
        take(wait(futures, return_when=FIRST_COMPLETED).done)


def ensure_image(item: Item, cache: ImageCache | None = None, force: bool = False,
                 renderers: dict | None = None, log=None) -> tuple[str, bytes, bool]:
    """One item through the cache in this process: (key, PNG bytes, whether it was cached).
    The Sphinx extension uses this; ``log(line)`` hears when a render starts and how long it
    took (a docs build is not silent while it draws)."""
    import time

    from .keys import gl_renderers, item_key
    cache = cache or ImageCache()
    key = item_key(item, renderers or gl_renderers([item]))
    data = None if force else cache.get(key)
    if data is not None:
        return key, data, True
    start = time.perf_counter()
    if log is not None:
        log(f"drawing {item.entry} ({item.name}.png) ...")
    with Ticker(f"still drawing {item.name}.png", enabled=log is not None, say=log, end=False):
        rendered = render_item(item, key)
    if log is not None:
        log(f"drew {item.entry} in {time.perf_counter() - start:.1f} s")
    cache.put(key, rendered.png)
    return key, rendered.png, False
