"""Writing images and arrays (PNG, EXR, NPY, NPZ), each committed all-or-nothing through
``sdfpbr.files``, and checking an output location before anything is rendered."""
from __future__ import annotations

import io as _io
import os
from pathlib import Path

import numpy as np

from ..errors import OutputError, SpecError
from ..files import longest_name, write_group
from .png_stream import write_png_stream

HDR_SUFFIXES = (".npy", ".exr")


def check_writable(path: str | Path, suffixes: tuple[str, ...] | None = None, what: str = "output") -> Path:
    """Fail early, before rendering, if ``path`` cannot be written."""
    if not str(path).strip():
        raise SpecError(f"{what} is empty: give a file name"
                        + (f" ending in {' or '.join(suffixes)}" if suffixes else ""))
    p = Path(path)
    if suffixes and p.suffix.lower() not in suffixes:
        raise SpecError(f"{what} {p} must end in {' or '.join(suffixes)}")
    parent = p.parent if str(p.parent) else Path(".")
    try:
        longest = longest_name(parent if parent.is_dir() else ".")
        if len(os.fsencode(p.name)) > longest:
            raise OutputError(f"cannot write {what}: its name is {len(os.fsencode(p.name))} bytes long; at most "
                              f"{longest} are written (sdfpbr writes a longer temporary name beside it first)")
        if p.is_dir():
            raise OutputError(f"{what} {p} is a directory")
        if p.exists() and not p.is_file():   # a FIFO, socket or device: the rename would replace it
            raise OutputError(f"{what} {p} is not a regular file (a FIFO, socket or device); give a file name")
        if not parent.is_dir():
            raise OutputError(f"cannot write {what} {p}: directory {parent} does not exist")
        if not os.access(parent, os.W_OK) or (p.exists() and not os.access(p, os.W_OK)):
            raise OutputError(f"cannot write {what} {p}: permission denied")
    except OSError as exc:   # a path longer than the system allows, a loop of symlinks, ...
        raise OutputError(f"cannot write {what}: {exc.strerror or exc}") from None
    except ValueError:       # a NUL in the name
        raise OutputError(f"cannot write {what}: its name holds a NUL character") from None
    return p


def check_outputs(spec, output: str | Path, hdr: str | Path | None = None, aov: str | Path | None = None) -> None:
    """Before rendering, everything that would make writing a chart's files fail or destroy
    something: each destination writable with its suffix, an .exr writer installed, no two
    outputs the same file, and no output that is one of the spec's inputs (its environment or
    texture files)."""
    outputs = {"output": (output, (".png",))}
    if hdr is not None:
        outputs["--hdr"] = (hdr, HDR_SUFFIXES)
    if aov is not None:
        outputs["--aov"] = (aov, (".npz",))
    seen: dict[Path, str] = {}
    inputs = {name: getattr(spec, name) for name in ("env", "base_color_texture", "orm_texture", "normal_texture")}
    inputs = {Path(v).resolve(): name for name, v in inputs.items() if v and Path(v).suffix}
    for what, (path, suffixes) in outputs.items():
        check_writable(path, suffixes, what)
        where = Path(path).resolve()
        if where in seen:
            raise SpecError(f"{what} {path} is also the {seen[where]}: give each output its own file")
        if where in inputs:
            raise SpecError(f"{what} {path} is the chart's {inputs[where]} input: writing it would replace it")
        seen[where] = what
    if hdr is not None:
        hdr_writer(hdr, np.zeros((1, 1, 3), np.float32))   # raises now if .exr cannot be written


def png_bytes(rgba: np.ndarray, metadata: dict[str, str] | None = None) -> bytes:
    """``rgba`` ((H, W, 4) uint8) as PNG file bytes (RGB when opaque), ``metadata`` as text."""
    buf = _io.BytesIO()
    write_png_stream(buf, _rgba(rgba), metadata)
    return buf.getvalue()


def png_writer(rgba: np.ndarray, metadata: dict[str, str] | None = None):
    """A writer for sdfpbr.files.write_group: the PNG of ``rgba``, encoded a block of rows at a
    time straight into the file (nothing image-sized is held but ``rgba`` itself)."""
    rgba = _rgba(rgba)
    def write(tmp: str) -> None:
        with open(tmp, "wb") as f:
            write_png_stream(f, rgba, metadata)
    return write


def _rgba(rgba: np.ndarray) -> np.ndarray:
    rgba = np.asarray(rgba)
    if rgba.dtype != np.uint8 or rgba.ndim != 3 or rgba.shape[2] != 4:
        raise ValueError(f"a PNG is written from (H, W, 4) uint8, not {rgba.dtype} {rgba.shape}")
    return rgba


def hdr_writer(path: str | Path, hdr: np.ndarray):
    """A writer of float32 linear radiance (H, W, 3), row 0 at the top, as .npy or .exr (by
    ``path``'s suffix); refused before anything is written when .exr has no OpenEXR."""
    hdr = np.ascontiguousarray(hdr, np.float32)
    if Path(path).suffix.lower() == ".npy":
        def write(tmp: str) -> None:
            with open(tmp, "wb") as f:
                np.save(f, hdr)
        return write
    try:
        import OpenEXR
    except ImportError:
        from ..extras import missing_extra
        raise missing_extra("exr", "writing .exr", "or use .npy") from None
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    def write(tmp: str) -> None:
        with OpenEXR.File(header, {"RGB": hdr}) as f:
            f.write(tmp)
    return write


def npz_writer(arrays: dict[str, np.ndarray]):
    def write(tmp: str) -> None:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, **arrays)
    return write


def write_png(path: str | Path, rgba: np.ndarray, metadata: dict[str, str] | None = None) -> None:
    write_group([(path, png_writer(rgba, metadata))])


def write_hdr(path: str | Path, hdr: np.ndarray) -> None:
    write_group([(path, hdr_writer(path, hdr))])


def write_npz(path: str | Path, arrays: dict[str, np.ndarray]) -> None:
    write_group([(path, npz_writer(arrays))])
