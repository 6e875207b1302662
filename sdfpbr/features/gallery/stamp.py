"""A build's inputs stamped as make does, so that a rebuild with nothing changed skips what
reading the entries costs (numpy, the glTF parser, ~180 specs, a GL context: 0.6 s of a 0.65 s
build that rendered nothing).

A full build records every input it reads while it collects the entries and makes their keys:
each file opened for reading and each directory listed (a Python audit hook; the fingerprint
taken before the read), the package's sources and shader modules, the shared libraries mapped
into the process (the GL driver among them; /proc/self/maps), the environment variables that
steer them and the interpreter. With the manifest it wrote, that is the build's stamp, one
file per (chart directory, output directory, shard) in the image cache. The next build
compares the stamp before it imports anything heavy: every input as recorded, the output
directory holding the manifest's images byte for byte, and every image still in the cache,
gives the recorded result without reading an entry; any difference (or anything unreadable)
takes the full build, which records a new stamp. An input a process memo spares the build
from reading must still be read for its key (keys._spec_for_key hashes every named file)."""
from __future__ import annotations

import hashlib
import json
import os
import stat
import sys
from pathlib import Path

STAMP_FORMAT = "sdfpbr-build-stamp-1"
# Variables that choose the GL driver and device, the cache, or the package's behaviour.
ENV_PREFIXES = ("SDFPBR_", "MESA_", "LIBGL_", "GALLIUM_", "LP_", "EGL_", "__EGL_", "__GLX_", "__GL_",
                "GLCONTEXT_", "CUDA_", "NVIDIA_", "LD_LIBRARY_PATH", "LD_PRELOAD", "DISPLAY", "WAYLAND_DISPLAY")
PACKAGE_ROOT = Path(__file__).resolve().parents[2]     # the sdfpbr package directory
# Kernel views, not inputs: their content changes from one read to the next.
PSEUDO_FILESYSTEMS = ("/proc/", "/sys/", "/dev/")

_WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_APPEND | os.O_TRUNC
HASHED_MAX = 8 << 20     # files up to this size are compared by content, larger ones by mtime
_active: list[InputLog] = []
_hooked = False


def fingerprint(path: str, by_content: bool = True) -> list | None:
    """What a path holds: a directory's listing, a file's content (size and sha256; size and
    mtime past HASHED_MAX or without ``by_content``), None if it is missing or unreadable.
    Contents, not mtimes, so an edit in the clock tick of the build's read is still seen."""
    try:
        if os.path.isdir(path):
            return ["dir", hashlib.sha256("\0".join(sorted(os.listdir(path))).encode()).hexdigest()]
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):   # a FIFO, a device: never opened (it could hang or never end)
            return ["special", stat.S_IFMT(st.st_mode)]
        if st.st_size > HASHED_MAX or not by_content:
            return ["stat", st.st_size, st.st_mtime_ns]
        with open(path, "rb") as f:
            return ["file", st.st_size, hashlib.sha256(f.read()).hexdigest()]
    except (OSError, ValueError):
        return None


def _audit(event: str, args: tuple) -> None:
    if not _active or event not in ("open", "os.scandir", "os.listdir"):
        return
    path = args[0] if args else None
    if isinstance(path, bytes):
        path = os.fsdecode(path)
    elif isinstance(path, os.PathLike):
        path = os.fspath(path)
    if not isinstance(path, str):
        return                       # a file descriptor: its file was recorded when opened
    if event == "open":
        mode, flags = args[1], args[2]
        writing = any(c in mode for c in "wax+") if isinstance(mode, str) else bool(flags & _WRITE_FLAGS)
        if writing:
            return                   # an output, not an input
    for log in _active:
        log.see(os.path.abspath(path))


class InputLog:
    """Inside ``with InputLog(exclude) as log:``, every file this process opens for reading
    and every directory it lists is recorded with its fingerprint, taken before the read;
    paths under ``exclude`` (the cache, which builds write) and kernel views are left out."""

    def __init__(self, exclude: Path):
        self.exclude = os.path.abspath(exclude) + os.sep
        self.paths: dict[str, list | None] = {}

    def see(self, path: str) -> None:
        if path not in self.paths and not path.startswith((self.exclude, *PSEUDO_FILESYSTEMS)):
            self.paths[path] = None          # first: fingerprint's own open comes back here
            self.paths[path] = fingerprint(path)

    def __enter__(self) -> InputLog:
        global _hooked
        if not _hooked:
            sys.addaudithook(_audit)     # process-wide and permanent; idle outside a log
            _hooked = True
        _active.append(self)
        return self

    def __exit__(self, *exc) -> None:
        _active.remove(self)


def package_files() -> dict[str, list | None]:
    """The fingerprint of every source and shader module of the package and of the directories
    holding them: taken when a full build starts, before it reads a module."""
    from ...shading.compose import shader_dir
    out = {}
    for root in (PACKAGE_ROOT, shader_dir()):
        for dirpath, dirnames, names in os.walk(root):
            dirnames[:] = [d for d in dirnames if d != "__pycache__"]
            out[dirpath] = fingerprint(dirpath)
            for name in names:
                if name.endswith((".py", ".glsl")):
                    path = os.path.join(dirpath, name)
                    out[path] = fingerprint(path)
    return out


def mapped_libraries() -> dict[str, list | None]:
    """The shared objects mapped into this process (the GL driver once a context exists) with
    their fingerprints; empty where /proc/self/maps cannot be read (no stamp is kept then)."""
    try:
        with open("/proc/self/maps") as f:
            lines = f.read().splitlines()
    except OSError:
        return {}
    paths = {parts[5] for parts in (line.split(None, 5) for line in lines) if len(parts) == 6}
    return {p: fingerprint(p, by_content=False) for p in sorted(paths)       # installed, not edited:
            if p.startswith("/") and ".so" in os.path.basename(p)}          # 48 MB to hash otherwise


def _environment() -> dict:
    return {"python": [sys.executable, sys.version],
            "env": {k: v for k, v in sorted(os.environ.items()) if k.startswith(ENV_PREFIXES)}}


def stamp_path(cache_dir: Path, chart_dir, out_dir, shard, root=None) -> Path:
    """The stamp of a build of ``chart_dir`` into ``out_dir`` (its ``shard``; with the tree
    ``root`` its entries are confined to, where one is given)."""
    where = [os.path.abspath(chart_dir), os.path.abspath(out_dir), shard]
    ident = json.dumps(where if root is None else [*where, os.path.abspath(root)])
    return cache_dir / "stamps" / (hashlib.sha256(ident.encode()).hexdigest()[:32] + ".json")


def record(path: Path, log: InputLog, packages: dict, manifest: dict) -> None:
    """Keep the stamp of a full build whose every image is in the cache (best effort)."""
    from ...errors import OutputError
    from ...files import write_bytes
    libraries = mapped_libraries()
    if not libraries:
        return
    stamp = {"format": STAMP_FORMAT, **_environment(), "paths": {**packages, **log.paths, **libraries},
             "manifest": manifest}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_bytes(path, json.dumps(stamp).encode())
    except (OSError, OutputError):
        pass


def unchanged(path: Path) -> tuple[dict | None, str]:
    """(the manifest the stamp at ``path`` recorded, "") if every input is as it was, else
    (None, what differs first)."""
    from ...errors import SpecError
    from ...inputs import read_json
    try:
        stamp = read_json(path, "build stamp")     # bounded: the stamp lies in a shared cache
        if stamp.get("format") != STAMP_FORMAT:
            return None, "no stamp of this version"
        for key, value in _environment().items():
            if stamp[key] != value:
                return None, f"the {'interpreter' if key == 'python' else 'environment'} changed"
        for p, print_ in stamp["paths"].items():
            if fingerprint(p, print_ is None or print_[0] != "stat") != print_:
                return None, f"{p} changed"
        return stamp["manifest"], ""
    except SpecError:
        return None, "no stamp" if not os.path.lexists(path) else "an unreadable stamp"
    except OSError:
        return None, "no stamp"
    except (ValueError, KeyError, TypeError, AttributeError):
        return None, "an unreadable stamp"
