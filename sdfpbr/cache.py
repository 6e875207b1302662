"""An on-disk cache of arrays keyed by content hashes. Writes are atomic (``sdfpbr.files``),
so an interrupted process never leaves a corrupt entry, and concurrent writers of one key
simply write the same bytes.

The whole cache directory (bakes, bench references, built images) is held under a size cap,
$SDFPBR_CACHE_MAX (default 2G): a write that takes it past the cap evicts the least recently
used entries (a read marks an entry used) down to 90 % of the cap. ``sdfpbr cache`` lists and
clears it."""
from __future__ import annotations

import hashlib
import json
import os
import re
import sys
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from .errors import OutputError, SpecError
from .files import TEMP_NAME, atomic_file, remove_stale_temps

if TYPE_CHECKING:   # numpy loads with the first array entry: a gallery build answered by its
    import numpy as np   # stamp reads no array and needs no numpy


def default_cache_dir() -> Path:
    env = os.environ.get("SDFPBR_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "sdfpbr"


DEFAULT_CACHE_MAX = "2G"
_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}


def cache_max() -> int | None:
    """The cache's size cap in bytes from $SDFPBR_CACHE_MAX ('500M', '2G', a byte count;
    'none': no cap)."""
    text = os.environ.get("SDFPBR_CACHE_MAX", DEFAULT_CACHE_MAX).strip()
    if text.lower() in ("none", "unlimited"):
        return None
    m = re.fullmatch(r"(\d+(?:\.\d*)?|\.\d+)\s*([kmgt]?)(?:i?b)?", text, re.I)
    value = float(m.group(1)) * _UNITS[m.group(2).upper()] if m else None
    if value is None or not value < 2**63:
        raise SpecError(f"SDFPBR_CACHE_MAX={text!r} is not a size: give bytes with an optional K, M, G or T "
                        f"suffix (e.g. 500M, 2G), or 'none' for no cap")
    return int(value)


def cache_entries(root: Path) -> list[tuple[Path, int, float]]:
    """(path, bytes, last use) of every cache file under ``root``, temporaries of live writers
    excluded."""
    out = []
    for dirpath, _, names in os.walk(root):
        for name in names:
            if TEMP_NAME.match(name):
                continue
            path = Path(dirpath) / name
            try:
                st = path.stat()
            except OSError:
                continue     # removed by another process meanwhile
            out.append((path, st.st_size, st.st_mtime))
    return out


def touch(path: Path) -> None:
    """Mark an entry used now (its mtime is its last use)."""
    try:
        os.utime(path)
    except OSError:
        pass


def enforce_cap(root: Path, limit: int | None = None) -> int:
    """Delete least recently used entries under ``root`` until it holds at most ``limit`` bytes
    (default: cache_max()); returns the bytes freed."""
    limit = cache_max() if limit is None else limit
    return 0 if limit is None else _evict(root, limit)[0]


def _evict(root: Path, limit: int, keep: int | None = None) -> tuple[int, int]:
    """(bytes freed, bytes left): past ``limit`` bytes under ``root``, the least recently used
    entries go until ``keep`` (default ``limit``) bytes are left."""
    entries = cache_entries(root)
    total = sum(size for _, size, _ in entries)
    freed = 0
    keep = limit if keep is None or total <= limit else keep
    for path, size, _ in sorted(entries, key=lambda e: e[2]):
        if total - freed <= keep:
            break
        try:
            path.unlink()
            freed += size
        except OSError:
            pass
    _tally[str(root)] = total - freed
    return freed, total - freed


# The bytes under each cache root as this process last counted them plus what it has written
# since: a write walks the cache (1 300 files: ~35 ms; a gallery build spent 1.1 s so) only
# when that tally could pass the cap. Other processes' writes count from this one's next walk.
# A full cache is cut to LOW_WATER of its cap, so the writes after an eviction do not each walk.
_tally: dict[str, int] = {}
LOW_WATER = 0.9


def after_write(root: Path, nbytes: int) -> None:
    """Keep ``root`` within the cap after this process wrote ``nbytes`` to it."""
    limit = cache_max()
    if limit is None:
        return
    known = _tally.get(str(root))
    if known is not None and known + nbytes <= limit:
        _tally[str(root)] = known + nbytes
    else:
        _evict(root, limit, keep=int(limit * LOW_WATER))


def clear(root: Path, kind: str | None = None) -> tuple[int, int]:
    """Delete every entry (or those of one kind: a subdirectory such as 'ibl' or 'build') and
    stale temporaries; returns (files, bytes) removed."""
    where = root / kind if kind else root
    files = size = 0
    for path, n, _ in cache_entries(where):
        try:
            path.unlink()
            files, size = files + 1, size + n
        except OSError:
            pass
    remove_stale_temporaries(where)
    return files, size


def remove_stale_temporaries(root: Path) -> int:
    """Delete the temporaries of writers that no longer run in every kind under ``root`` (a
    worker that exits with its killed parent may leave one mid-write, in a kind the next run
    does not write to); returns how many."""
    return sum(remove_stale_temps(Path(dirpath)) for dirpath, _, _ in os.walk(root))


def content_key(*parts) -> str:
    h = hashlib.sha256()
    for part in parts:
        if isinstance(part, bytes):
            h.update(part)
        else:
            h.update(json.dumps(part, sort_keys=True, default=str).encode())
        h.update(b"\0")
    return h.hexdigest()


CHECK = "__check__"   # the array holding an entry's checksum


def checksum(key: str, arrays: dict[str, np.ndarray]) -> np.ndarray:
    """sha256 over the key and every array's name, dtype, shape and bytes, as uint8[32]."""
    import numpy as np
    h = hashlib.sha256(key.encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"\0{name}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.reshape(-1).view(np.uint8) if a.size else b"")   # its bytes, not a copy of them
    return np.frombuffer(h.digest(), np.uint8)


class ArrayCache:
    """Entries are .npz files under root/kind/, each with a checksum of its key and content. An
    entry that does not verify (truncated, flipped bytes, another key's, non-finite floats) is
    reported once on stderr, deleted and rebuilt by the caller: rendering never fails or goes
    wrong because of the cache."""

    def __init__(self, root: Path | None = None, enabled: bool = True):
        self.root = Path(root) if root else default_cache_dir()
        self.enabled = enabled
        # reading_only's state, per thread: a still chart another thread draws during an
        # animation keeps writing.
        self._local = threading.local()
        if enabled:
            cache_max()   # a malformed $SDFPBR_CACHE_MAX is refused before any work

    def _path(self, kind: str, key: str) -> Path:
        return self.root / kind / f"{key}.c.npz"   # .c: checksummed (older entries are not read)

    def get(self, kind: str, key: str, require_finite: bool = True) -> dict[str, np.ndarray] | None:
        if not self.enabled:
            return None
        path = self._path(kind, key)
        if not path.exists():
            return None
        import numpy as np
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
        except Exception as exc:   # zipfile, zlib, numpy and OS errors alike: unreadable
            return self._discard(path, f"unreadable ({exc.__class__.__name__})")
        stored = arrays.pop(CHECK, None)
        if stored is None or not np.array_equal(stored, checksum(key, arrays)):
            return self._discard(path, "checksum mismatch")
        if require_finite and any(a.dtype.kind == "f" and not np.isfinite(a).all() for a in arrays.values()):
            return self._discard(path, "non-finite values")
        touch(path)
        return arrays

    def _discard(self, path: Path, reason: str) -> None:
        print(f"sdfpbr: cache entry {path} is bad ({reason}); deleted, rebuilding it", file=sys.stderr)
        try:
            path.unlink()
        except OSError:
            pass
        return None

    @contextmanager
    def reading_only(self, kinds: tuple[str, ...] | None = None):
        """Entries are read but none are written in the block (``kinds``: none of those kinds):
        an animation's frames each bake their own stage probe (the light moves), which would
        fill the cache for nothing."""
        was = self._blocked()
        self._local.blocked = (True, was[1]) if kinds is None else (was[0], was[1] | frozenset(kinds))
        try:
            yield self
        finally:
            self._local.blocked = was

    def _blocked(self) -> tuple[bool, frozenset]:
        """(no kind is written, the kinds not written) in this thread."""
        return getattr(self._local, "blocked", (False, frozenset()))

    def put(self, kind: str, key: str, arrays: dict[str, np.ndarray]) -> None:
        every, kinds = self._blocked()
        if not self.enabled or every or kind in kinds:
            return
        import numpy as np
        path = self._path(kind, key)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            remove_stale_temps(path.parent)   # a killed bake's temporaries
            with atomic_file(path, durable=False) as f:   # get() verifies its checksum
                np.savez(f, **arrays, **{CHECK: checksum(key, arrays)})
            after_write(self.root, path.stat().st_size)
        except (OSError, OutputError):
            pass    # a read-only or full cache location only costs speed
