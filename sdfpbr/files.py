"""The one way sdfpbr writes a file: under a temporary name beside the destination, fsynced (all
but cache entries, which their readers verify), then renamed into place. A rename is atomic on one
filesystem, so a reader sees no file or a complete one, never a torn one, and a failure never
clobbers the old file.

Temporary names carry the writer's pid (``.<name>.<random>.<pid>.tmp[<suffix>]``), so the
temporaries of a killed writer can be told from a live writer's and removed
(``remove_stale_temps``)."""
from __future__ import annotations

import os
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Callable

from .errors import OutputError

# Matches the names atomic_path makes; group 1 is the writer's pid.
TEMP_NAME = re.compile(r"^\..+\.(\d+)\.tmp(\.\w+)?$")


# What a temporary's name adds to its destination's: ".", ".", 8 random characters, ".", the
# writer's pid (at most 7 digits on Linux), ".tmp" and the writer's suffix (at most ".tmp.webp").
TEMP_NAME_EXTRA = 1 + 1 + 8 + 1 + 7 + 4 + 9


def longest_name(directory: str | Path) -> int:
    """The longest file name (bytes) sdfpbr can write in ``directory``: the filesystem's limit
    less what a temporary's name adds."""
    try:
        limit = os.pathconf(directory, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    return max(limit - TEMP_NAME_EXTRA, 1)


def _temp_beside(p: Path, suffix: str) -> str:
    """A new empty temporary beside ``p``, named as TEMP_NAME describes; the temporaries a
    killed writer of ``p`` left behind are removed first."""
    remove_stale_temps(p.parent if str(p.parent) else ".", prefix=f".{p.name}.")
    try:
        fd, tmp = tempfile.mkstemp(dir=p.parent if str(p.parent) else ".", prefix=f".{p.name}.",
                                   suffix=f".{os.getpid()}.tmp{suffix}")
        os.close(fd)
    except OSError as exc:
        raise OutputError(f"cannot write {p}: {exc.strerror or exc}") from None
    return tmp


@contextmanager
def atomic_path(path: str | Path, suffix: str = ""):
    """Yield a temporary path beside ``path`` (ending in ``suffix``, for writers that pick a
    format by extension); rename it into place only if the block succeeds."""
    p = Path(path)
    tmp = _temp_beside(p, suffix)
    try:
        yield tmp
        os.chmod(tmp, 0o644)
        os.replace(tmp, p)
    except OSError as exc:
        _unlink(tmp)
        raise OutputError(f"cannot write {p}: {exc.strerror or exc}") from None
    except BaseException:
        _unlink(tmp)
        raise


@contextmanager
def atomic_file(path: str | Path, before_rename: Callable[[], None] | None = None, durable: bool = True):
    """A binary file object on a temporary beside ``path``, fsynced and renamed into place when
    the block succeeds. ``before_rename`` runs between the fsync and the rename (a test hook).
    ``durable=False``: no fsync, for files whose reader verifies them (cache entries: one torn
    by a power cut fails its check and is made again); the rename is atomic all the same."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            yield f
            if durable:
                f.flush()
                os.fsync(f.fileno())
        if before_rename is not None:
            before_rename()


def write_bytes(path: str | Path, data: bytes, before_rename: Callable[[], None] | None = None,
                durable: bool = True) -> None:
    with atomic_file(path, before_rename, durable) as f:
        f.write(data)


def write_group(items: list[tuple[str | Path, Callable[[str], None]]]) -> None:
    """Several files, all or none: each ``writer(tmp)`` writes its file to a temporary beside
    its destination (same suffix, for writers that pick a format by it); when every one has
    succeeded they are fsynced and renamed into place; if any fails, every temporary is removed
    and every destination keeps what it had."""
    staged: list[tuple[str, Path]] = []
    try:
        for path, writer in items:
            p = Path(path)
            tmp = _temp_beside(p, p.suffix)
            staged.append((tmp, p))
            try:
                writer(tmp)
                with open(tmp, "rb+") as f:
                    os.fsync(f.fileno())
                os.chmod(tmp, 0o644)
            except OSError as exc:   # no strerror: a short write (numpy's), the disk full or the file too large
                reason = exc.strerror or f"the disk is full or the file too large ({exc})"
                raise OutputError(f"cannot write {p}: {reason}") from None
        for tmp, p in staged:
            os.replace(tmp, p)
    except BaseException:
        for tmp, _ in staged:
            _unlink(tmp)
        raise


def _unlink(path: str | Path) -> bool:
    try:
        os.unlink(path)
        return True
    except OSError:
        return False


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:          # exists, owned by someone else
        pass
    # An exited process waits as a zombie until it is reaped (an orphan's by init, here up to
    # ~1 s later): it writes nothing more.
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return f.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except (OSError, IndexError):
        return True


def remove_stale_temps(directory: str | Path, prefix: str = "") -> int:
    """Delete temporary files (those whose names start with ``prefix``) of writers that no
    longer run (a killed process); a live writer's temporaries are left alone, so processes
    sharing a directory cannot hurt each other."""
    try:
        names = os.listdir(directory)
    except OSError:
        return 0
    removed = 0
    for name in names:
        m = TEMP_NAME.match(name) if name.startswith(prefix) else None
        if m and not _alive(int(m.group(1))):
            removed += _unlink(Path(directory) / name)
    return removed
