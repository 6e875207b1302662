"""An on-disk cache of arrays keyed by content hashes. Writes are atomic (``sdfpbr.files``),
so an interrupted process never leaves a corrupt entry, and concurrent writers of one key
simply write the same bytes."""
from __future__ import annotations

import hashlib
import json
import os
import sys
from pathlib import Path

import numpy as np

from .errors import OutputError
from .files import atomic_file


def default_cache_dir() -> Path:
    env = os.environ.get("SDFPBR_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "sdfpbr"


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
    h = hashlib.sha256(key.encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"\0{name}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.tobytes())
    return np.frombuffer(h.digest(), np.uint8)


class ArrayCache:
    """Entries are .npz files under root/kind/, each with a checksum of its key and content. An
    entry that does not verify (truncated, flipped bytes, another key's, non-finite floats) is
    reported once on stderr, deleted and rebuilt by the caller: rendering never fails or goes
    wrong because of the cache."""

    def __init__(self, root: Path | None = None, enabled: bool = True):
        self.root = Path(root) if root else default_cache_dir()
        self.enabled = enabled

    def _path(self, kind: str, key: str) -> Path:
        return self.root / kind / f"{key}.c.npz"   # .c: checksummed (older entries are not read)

    def get(self, kind: str, key: str, require_finite: bool = True) -> dict[str, np.ndarray] | None:
        if not self.enabled:
            return None
        path = self._path(kind, key)
        if not path.exists():
            return None
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
        return arrays

    def _discard(self, path: Path, reason: str) -> None:
        print(f"sdfpbr: cache entry {path} is bad ({reason}); deleted, rebuilding it", file=sys.stderr)
        try:
            path.unlink()
        except OSError:
            pass
        return None

    def put(self, kind: str, key: str, arrays: dict[str, np.ndarray]) -> None:
        if not self.enabled:
            return
        path = self._path(kind, key)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            with atomic_file(path) as f:
                np.savez(f, **arrays, **{CHECK: checksum(key, arrays)})
        except (OSError, OutputError):
            pass    # a read-only or full cache location only costs speed
