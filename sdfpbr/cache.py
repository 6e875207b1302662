"""An on-disk cache of arrays keyed by content hashes. Writes are atomic (``sdfpbr.files``),
so an interrupted process never leaves a corrupt entry, and concurrent writers of one key
simply write the same bytes.

The whole cache directory (bakes, bench references, built images) is held under a size cap,
$SDFPBR_CACHE_MAX (default 2G): a write that takes it past the cap evicts the least recently
used entries (a read marks an entry used) down to 90 % of the cap. ``sdfpbr cache`` lists and
clears it.

The cache owns only its own files. $SDFPBR_CACHE_DIR may name a folder that holds other
things (a thesis, photos, another tool's ``build`` folder): eviction, the cap, ``sdfpbr cache``
(its listing, sizes and ``--clear``) and the sweep of dead writers' temporaries count and
delete only the cache's *entries*, which are recognised by two things together:

* the marker file ``<root>/.sdfpbr-cache`` (MARKER), which sdfpbr writes with its first write
  into a root; a folder without it holds no entries as far as these operations go (nothing is
  counted, nothing deleted);
* sdfpbr's naming (``own_entry``): a regular file (not a symlink) directly in a *kind* folder
  (a subfolder of the root, itself not a symlink, named like ``ibl``, ``dfg``, ``build``:
  KIND_NAME) named ``<sha256 hex>.c.npz`` (ArrayCache; ``<sha256 hex>.npz``, the unchecked
  entries of older versions, likewise), and in ``build/`` also ``<sha256 hex>.png`` (the
  gallery's image cache) and ``keys.json`` (its key memo), and ``build/stamps/<32 hex>.json``
  (build stamps). Anything else, anywhere under the root, is never counted or removed; the
  temporaries swept are those of such names (``.<name>.<random>.<pid>.tmp``) in kind folders.

Foreign files do not count toward the cap: the cap bounds what sdfpbr stores, and counting
files it may not delete would make a folder whose other files alone pass the cap evict every
entry with every write (a cache that never keeps anything).

Entries of older versions in a root without the marker (an existing ~/.cache/sdfpbr, or a
folder $SDFPBR_CACHE_DIR names) are adopted with the first write of this version, which writes
the marker: by the naming rule above they are sdfpbr's own (a content hash with sdfpbr's
suffix in a kind folder), and files not so named stay foreign. ``sdfpbr cache`` adopts the
default location (``$XDG_CACHE_HOME/sdfpbr``: a folder named for sdfpbr) at once; a folder
$SDFPBR_CACHE_DIR names is adopted only by a write."""
from __future__ import annotations

import hashlib
import json
import os
import re
import stat
import sys
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from .errors import OutputError, SpecError
from .files import atomic_file, remove_stale_temps

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


MARKER = ".sdfpbr-cache"    # in the cache root: sdfpbr has written here (see the module's docstring)
MARKER_TEXT = ("This folder is an sdfpbr cache ($SDFPBR_CACHE_DIR, else $XDG_CACHE_HOME/sdfpbr).\n"
               "sdfpbr counts and deletes only its own entries in it (kind folders such as ibl/ and\n"
               "build/ holding files named by sha256 hashes); any other file here is left alone.\n")
KIND_NAME = re.compile(r"[a-z][a-z0-9_-]{0,63}")
HEX_KEY = re.compile(r"[0-9a-f]{64}")
_ENTRY = re.compile(r"[0-9a-f]{64}(?:\.c)?\.npz")              # ArrayCache's (.npz: older versions')
_BUILD_ENTRY = re.compile(r"[0-9a-f]{64}\.png|keys\.json")      # the image cache's, its key memo
_STAMP = re.compile(r"[0-9a-f]{32}\.json")                      # build/stamps/
STAMPS = "stamps"
# A temporary of an entry's write (sdfpbr.files: ".<name>.<random>.<pid>.tmp[<suffix>]"): its
# destination, group 1, is an entry name (tests and killed writers of older keys use short stems).
_TEMP_OF = re.compile(r"\.([0-9A-Za-z_-]{1,64}\.(?:c\.npz|npz|png|json))\.[^./]+\.\d+\.tmp(?:\.\w+)?")


def owned(root: Path) -> bool:
    """Whether ``root`` carries sdfpbr's marker (sdfpbr has written there)."""
    return os.path.isfile(Path(root) / MARKER)


def claim(root: Path) -> None:
    """Make ``root`` (and its parents) and mark it as sdfpbr's cache, if not yet; every writer
    of an entry calls this first. OSError where it cannot (the writer's own handling applies)."""
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    marker = root / MARKER
    if os.path.lexists(marker):
        return
    try:
        fd = os.open(marker, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o644)
    except FileExistsError:
        return          # another process marked it meanwhile
    try:
        os.write(fd, MARKER_TEXT.encode())
    finally:
        os.close(fd)


def own_entry(kind: str, name: str, sub: str | None = None) -> bool:
    """Whether ``name`` in the kind folder ``kind`` (or in its subfolder ``sub``) is named as
    sdfpbr names its entries."""
    if sub is not None:
        return kind == "build" and sub == STAMPS and bool(_STAMP.fullmatch(name))
    return bool(_ENTRY.fullmatch(name) or (kind == "build" and _BUILD_ENTRY.fullmatch(name)))


def _kind_dirs(root: Path) -> list[str]:
    """The subfolders of ``root`` named as kinds are (KIND_NAME); symlinks to folders are left
    out, as os.walk left them out before (bakes shared by linking a kind in are not evicted)."""
    try:
        with os.scandir(root) as it:
            return sorted(e.name for e in it if KIND_NAME.fullmatch(e.name) and e.is_dir(follow_symlinks=False))
    except OSError:
        return []


def _folders(root: Path, kind: str) -> list[tuple[Path, str | None]]:
    """(folder, subfolder name or None) where entries of ``kind`` lie."""
    folders = [(root / kind, None)]
    if kind == "build":
        folders.append((root / kind / STAMPS, STAMPS))
    return folders


def _own_files(root: Path, kind: str):
    """(path, stat) of every entry of ``kind`` under ``root``: own names, regular files only."""
    for folder, sub in _folders(root, kind):
        if sub is not None and folder.is_symlink():
            continue
        try:
            with os.scandir(folder) as it:
                found = [e for e in it if own_entry(kind, e.name, sub)]
        except OSError:
            continue
        for e in found:
            try:
                st = e.stat(follow_symlinks=False)
            except OSError:
                continue     # removed by another process meanwhile
            if stat.S_ISREG(st.st_mode):
                yield Path(e.path), st


def kinds(root: Path) -> list[str]:
    """The kinds of entry in the cache at ``root``: kind folders that hold an entry, or nothing
    at all (a kind just cleared). A folder of other files only is not one; a root without the
    marker has none."""
    root = Path(root)
    if not owned(root):
        return []
    out = []
    for kind in _kind_dirs(root):
        if next(_own_files(root, kind), None) is not None:
            out.append(kind)
            continue
        try:
            if not os.listdir(root / kind):
                out.append(kind)
        except OSError:
            pass
    return out


def cache_entries(root: Path, kind: str | None = None) -> list[tuple[Path, int, float]]:
    """(path, bytes, last use) of every entry sdfpbr wrote under ``root`` (of one ``kind``):
    the module docstring says how they are told from other files, which are never listed.
    Temporaries of live writers are not entries."""
    root = Path(root)
    if not owned(root):
        return []
    out = []
    for k in _kind_dirs(root) if kind is None else [kind]:
        if not KIND_NAME.fullmatch(k) or (root / k).is_symlink():
            continue
        out.extend((path, st.st_size, st.st_mtime) for path, st in _own_files(root, k))
    return out


def touch(path: Path) -> None:
    """Mark an entry used now (its mtime is its last use)."""
    try:
        os.utime(path)
    except OSError:
        pass


def enforce_cap(root: Path, limit: int | None = None) -> int:
    """Delete least recently used entries under ``root`` until its entries take at most
    ``limit`` bytes (default: cache_max()); returns the bytes freed. Only sdfpbr's entries are
    counted and deleted (cache_entries)."""
    limit = cache_max() if limit is None else limit
    return 0 if limit is None else _evict(root, limit)[0]


def _evict(root: Path, limit: int, keep: int | None = None) -> tuple[int, int]:
    """(bytes freed, bytes left): past ``limit`` bytes of entries under ``root``, the least
    recently used entries go until ``keep`` (default ``limit``) bytes are left. Other files in
    the folder neither count nor go (module docstring)."""
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
    stale temporaries of entries; returns (files, bytes) removed. Only sdfpbr's entries go
    (cache_entries): other files in the folder stay, and a root without the marker loses
    nothing."""
    files = size = 0
    for path, n, _ in cache_entries(root, kind):
        try:
            path.unlink()
            files, size = files + 1, size + n
        except OSError:
            pass
    remove_stale_temporaries(root, kind)
    return files, size


def remove_stale_temporaries(root: Path, kind: str | None = None) -> int:
    """Delete the temporaries of writers that no longer run in every kind under ``root`` (or in
    ``kind``): a worker that exits with its killed parent may leave one mid-write, in a kind the
    next run does not write to. Only temporaries of entries' names in kind folders of a marked
    root go; returns how many."""
    root = Path(root)
    if not owned(root):
        return 0
    removed = 0
    for k in _kind_dirs(root) if kind is None else [kind]:
        if not KIND_NAME.fullmatch(k):     # a kind named by its writer may be a linked folder
            continue
        for folder, _ in _folders(root, k):
            try:
                names = os.listdir(folder)
            except OSError:
                continue
            dests = {m.group(1) for m in map(_TEMP_OF.fullmatch, names) if m}
            removed += sum(remove_stale_temps(folder, prefix=f".{dest}.") for dest in sorted(dests))
    return removed


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

    def path(self, kind: str, key: str) -> Path:
        """``<root>/<kind>/<name>.c.npz``, the name being the key where it is a sha256 hex
        digest (every key sdfpbr makes: content_key) and the sha256 of the key otherwise, so
        that every entry is named as the cache recognises its own (module docstring). .c:
        checksummed (older entries are not read)."""
        if not isinstance(kind, str) or not KIND_NAME.fullmatch(kind):
            raise ValueError(f"cache kind {kind!r} is not a lower-case word ({KIND_NAME.pattern})")
        name = key if HEX_KEY.fullmatch(key) else hashlib.sha256(key.encode()).hexdigest()
        return self.root / kind / f"{name}.c.npz"

    _path = path

    def get(self, kind: str, key: str, require_finite: bool = True) -> dict[str, np.ndarray] | None:
        if not self.enabled:
            return None
        path = self.path(kind, key)
        if not path.is_file():    # missing, or not a file sdfpbr wrote (a FIFO would hang np.load)
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
        path = self.path(kind, key)
        try:
            claim(self.root)
            path.parent.mkdir(parents=True, exist_ok=True)
            remove_stale_temporaries(self.root, kind)   # a killed bake's temporaries
            with atomic_file(path, durable=False) as f:   # get() verifies its checksum
                np.savez(f, **arrays, **{CHECK: checksum(key, arrays)})
            after_write(self.root, path.stat().st_size)
        except (OSError, OutputError):
            pass    # a read-only or full cache location only costs speed
