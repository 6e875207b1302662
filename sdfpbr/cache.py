"""An on-disk cache of arrays keyed by content hashes. Writes are atomic (``sdfpbr.files``),
so an interrupted process never leaves a corrupt entry, and concurrent writers of one key
simply write the same bytes."""
from __future__ import annotations

import hashlib
import json
import os
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


class ArrayCache:
    def __init__(self, root: Path | None = None, enabled: bool = True):
        self.root = Path(root) if root else default_cache_dir()
        self.enabled = enabled

    def _path(self, kind: str, key: str) -> Path:
        return self.root / kind / f"{key}.npz"

    def get(self, kind: str, key: str) -> dict[str, np.ndarray] | None:
        if not self.enabled:
            return None
        path = self._path(kind, key)
        try:
            with np.load(path) as data:
                return {k: data[k] for k in data.files}
        except (OSError, ValueError, EOFError):   # missing, or unreadable: recompute
            return None

    def put(self, kind: str, key: str, arrays: dict[str, np.ndarray]) -> None:
        if not self.enabled:
            return
        path = self._path(kind, key)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            with atomic_file(path) as f:
                np.savez(f, **arrays)
        except (OSError, OutputError):
            pass    # a read-only or full cache location only costs speed
