"""The one way sdfpbr reads a file that an input names: a spec, an environment, a texture, a
glTF asset and its buffers, a shard manifest, a Sphinx directive's entry.

Each read checks, before it reads a byte, that the path names a regular file (not a FIFO,
which would hang, nor a device such as /dev/zero, which never ends) and that the file is no
larger than its kind's limit (INPUT_LIMITS); structured text (JSON, TOML) is also bounded in
how deeply it nests. A path that an asset or an entry names relative to its own folder is
confined to that folder (``confined``): after percent-decoding and with symlinks resolved it
must stay inside, and the refusal reads the same whether the outside file exists or not.
Every refusal is a SpecError: one line, exit status 2.

The package also decodes what it reads where a format needs it: ``environment`` reads an
environment file (.npy, .exr, Radiance .hdr through ``rgbe``) into float32 radiance, so the
render path takes pixels from here and never comes back to a reader."""
from __future__ import annotations

import os
import stat
from pathlib import Path

from ..errors import SpecError

MIB = 1 << 20
# The largest file of each kind sdfpbr reads, in bytes. An environment may be 16384 x 16384
# float32 RGBA (inputs.environment.MAX_ENV_TEXELS), plus its header; an image of 2^26 texels is at most
# 256 MiB as RGBA8 before compression (gpu.textures); a glTF asset's JSON, a GLB or a buffer
# carries its images.
INPUT_LIMITS = {
    "spec": 4 * MIB,          # TOML: a spec, a gallery entry, a docs entry
    "manifest": 64 * MIB,     # JSON a build wrote: a shard's manifest
    "environment": 4096 * MIB + MIB,
    "image": 512 * MIB,
    "gltf": 1024 * MIB,       # a .gltf, a .glb or a buffer it names
}
# The longest JSON text parsed (a .gltf, a GLB's JSON chunk, a manifest): parsed, a few bytes of
# small values become a 50-100-byte Python object each ('[[],[],...]': 2.4 GB for 128 MiB), so
# the text is held tighter than the files that carry images.
MAX_JSON_BYTES = 128 * MIB
# The deepest nesting of JSON or TOML read: a spec's arrays are 2 deep inside 2 tables, a
# glTF's extensions a few more; 64 leaves room and stays far from Python's recursion limit.
MAX_NESTING = 64


def printable(text) -> str:
    """``text`` with its control (unprintable) characters escaped as repr escapes them: a path
    or a name from an input is shown so, since a terminal would act on an escape sequence and
    a newline would make a message two lines."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


def human_size(n: int) -> str:
    for unit, size in (("GiB", 1 << 30), ("MiB", MIB), ("KiB", 1 << 10)):
        if n >= size:
            return f"{n / size:.4g} {unit}"
    return f"{n} bytes"


def _check_stat(st: os.stat_result, path: Path, what: str, kind: str) -> None:
    if stat.S_ISDIR(st.st_mode):
        raise SpecError(f"{what} {printable(path)} is a directory, not a file")
    if not stat.S_ISREG(st.st_mode):
        raise SpecError(f"{what} {printable(path)} is not a regular file (a FIFO, socket or device is not read)")
    limit = INPUT_LIMITS[kind]
    if st.st_size > limit:
        raise SpecError(f"{what} {printable(path)} is {human_size(st.st_size)}; at most {human_size(limit)} is read")


def _os_error(exc: OSError, path: Path, what: str) -> SpecError:
    if isinstance(exc, FileNotFoundError):
        return SpecError(f"{what} {printable(path)} does not exist")
    if isinstance(exc, IsADirectoryError):
        return SpecError(f"{what} {printable(path)} is a directory, not a file")
    return SpecError(f"cannot read {what} {printable(path)}: {exc.strerror or exc}")


def check_input(path: str | Path, what: str, kind: str) -> Path:
    """``path`` if it names a regular file within ``kind``'s size limit (for readers that
    open the file themselves: OpenEXR, numpy's memory map); a SpecError otherwise. Only a
    stat: a FIFO is not opened."""
    p = Path(path)
    try:
        st = os.stat(p)
    except (OSError, ValueError) as exc:   # ValueError: a NUL in the name
        raise _os_error(exc, p, what) if isinstance(exc, OSError) else SpecError(f"{what} {p!r}: not a file name")
    _check_stat(st, p, what, kind)
    return p


def read_input(path: str | Path, what: str, kind: str) -> bytes:
    """The bytes of the regular file ``path``, at most ``kind``'s limit. It is opened without
    blocking (a FIFO opened for reading waits for a writer), checked on the open descriptor,
    and read no further than the limit (a file that grows, or a /proc file that reports size 0,
    cannot run on)."""
    p = Path(path)
    limit = INPUT_LIMITS[kind]
    try:
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except (OSError, ValueError) as exc:
        raise _os_error(exc, p, what) if isinstance(exc, OSError) else SpecError(f"{what} {p!r}: not a file name")
    try:
        _check_stat(os.fstat(fd), p, what, kind)
        os.set_blocking(fd, True)
        chunks, total = [], 0
        while True:
            chunk = os.read(fd, min(8 * MIB, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > limit:
                raise SpecError(f"{what} {printable(p)} holds more than {human_size(limit)}; at most that is read")
        return b"".join(chunks)
    except OSError as exc:
        raise _os_error(exc, p, what) from None
    finally:
        os.close(fd)


def read_input_text(path: str | Path, what: str, kind: str) -> str:
    """read_input as UTF-8 text (a byte-order mark, which Windows editors write, dropped)."""
    try:
        return read_input(path, what, kind).decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise SpecError(f"cannot read {what} {printable(path)}: not UTF-8 text (byte {exc.start})") from None


def nesting_depth(value) -> int:
    """How deeply lists and dicts nest in ``value`` (a scalar: 0), without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, depth = stack.pop()
        children = item.values() if isinstance(item, dict) else item if isinstance(item, (list, tuple)) else None
        if children is None:
            continue
        deepest = max(deepest, depth)
        if depth > MAX_NESTING:
            break
        stack.extend((c, depth + 1) for c in children)
    return deepest


def check_nesting(value, where: str):
    """``value`` if it nests at most MAX_NESTING deep; a SpecError otherwise."""
    if nesting_depth(value) > MAX_NESTING:
        raise SpecError(f"{where}: values nested more than {MAX_NESTING} deep")
    return value


def parse_json(text: str | bytes, where: str):
    """JSON text as Python values, nesting bounded; a SpecError (one line) when malformed."""
    import json
    if len(text) > MAX_JSON_BYTES:
        raise SpecError(f"{where}: its JSON is {human_size(len(text))}; at most {human_size(MAX_JSON_BYTES)} is parsed")
    try:
        value = json.loads(text)
    except RecursionError:
        raise SpecError(f"{where}: values nested more than {MAX_NESTING} deep") from None
    except (ValueError, UnicodeDecodeError) as exc:   # JSONDecodeError is a ValueError
        raise SpecError(f"{where}: malformed JSON: "
                        f"{str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None
    return check_nesting(value, where)


def read_json(path: str | Path, what: str, kind: str = "manifest"):
    """A JSON file, read as read_input does and parsed as parse_json does."""
    return parse_json(read_input(path, what, kind), f"{what} {printable(path)}")


def outside_refusal(base: str | Path, name, what: str) -> SpecError:
    """The one message for a file named outside the folder ``base`` (whether or not it exists)."""
    return SpecError(f"{what}: {name!r} is outside the folder {str(base)!r}; only files inside it are read")


def plain_relative(name) -> bool:
    """Whether ``name`` is a plain relative path: not empty, not absolute, not a home (~) or
    Windows root, no URI scheme (file:, http:, a drive letter C:), no NUL."""
    from urllib.parse import urlsplit
    return (isinstance(name, str) and bool(name) and "\0" not in name and not os.path.isabs(name)
            and not name.startswith(("\\", "~")) and not urlsplit(name).scheme)


def confined(base: str | Path, name: str, what: str) -> Path:
    """The file ``name`` (a relative path an asset or entry gives, percent-decoded by the
    caller where its format says so) inside the folder ``base``, with symlinks resolved. A
    name that is not plain_relative, or a path that leads outside ``base`` (through '..' or a
    symlink) is refused with the same words whether or not the outside file exists."""
    refusal = outside_refusal(base, name, what)
    if not plain_relative(name):
        raise refusal
    root = Path(os.path.realpath(base))
    target = Path(os.path.realpath(root / name))
    if target != root and root not in target.parents:
        raise refusal
    return target
