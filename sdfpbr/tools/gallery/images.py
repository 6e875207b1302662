"""Images by key: the verified on-disk cache, rendering one item into PNG bytes that carry its
key, and the kill-point test hook every build write passes through."""
from __future__ import annotations

import io
import os
import signal
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from ...cache import default_cache_dir
from ...errors import OutputError
from ...files import remove_stale_temps, write_bytes
from .entries import Item
from .keys import gl_renderers, item_key

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


def write_file(path: Path, data: bytes, phase: str) -> None:
    """An atomic write (sdfpbr.files) with the kill points ``phase``-temp (written, not yet
    renamed) and ``phase`` (in place)."""
    write_bytes(path, data, before_rename=lambda: checkpoint(phase + "-temp"))
    checkpoint(phase)


def png_key(data: bytes) -> str | None:
    """The build key stored in a PNG, or None if the bytes are not a complete, valid PNG."""
    from PIL import Image
    try:
        with Image.open(io.BytesIO(data)) as im:
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
            write_file(self.path(key), data, "cache")
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
