"""Headless OpenGL contexts: EGL (Mesa llvmpipe on a CPU, the NVIDIA driver on a GPU) and
OSMesa as a fallback. Only this module knows how contexts are made; everything else takes a
``moderngl.Context``."""
from __future__ import annotations

import ctypes
import ctypes.util
import os
from dataclasses import dataclass

import moderngl

from ..errors import GLUnavailable

BACKENDS = ("auto", "egl", "osmesa")
REQUIRED_GL = 450   # compute shaders and image load/store for the IBL bake
GL_TEXTURE_CUBE_MAP_SEAMLESS = 0x884F

INSTALL_HINT = ("install Mesa's EGL driver (Debian/Ubuntu: apt-get install libegl1 libegl-mesa0 "
                "libgl1-mesa-dri) or OSMesa (apt-get install libosmesa6)")


class _OSMesaLoader:
    """Makes an OSMesa context current and hands moderngl its GL entry points."""

    # OSMesa attribute names from osmesa.h
    _FORMAT, _RGBA, _PROFILE, _CORE, _MAJOR, _MINOR = 0x22, 0x1908, 0x33, 0x34, 0x36, 0x37

    def __init__(self) -> None:
        # $SDFPBR_LIBOSMESA names the library to load instead of searching (like glcontext's
        # $GLCONTEXT_LINUX_LIBEGL for EGL); the fault tests point both at missing files.
        override = os.environ.get("SDFPBR_LIBOSMESA")
        name = ctypes.util.find_library("OSMesa")
        lib = None
        candidates = (override,) if override else (name, "libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so")
        for candidate in filter(None, candidates):
            try:
                lib = ctypes.CDLL(candidate)
                break
            except OSError:
                continue
        if lib is None:
            raise GLUnavailable(f"OSMesa backend: {override or 'libOSMesa'} not found; apt-get install libosmesa6")
        if not all(hasattr(lib, f) for f in ("OSMesaCreateContextAttribs", "OSMesaMakeCurrent",
                                             "OSMesaGetProcAddress", "OSMesaDestroyContext")):
            raise GLUnavailable(f"OSMesa backend: {override or name} is not an OSMesa library "
                                "(no OSMesaCreateContextAttribs); apt-get install libosmesa6")
        lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
        lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
        lib.OSMesaMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_int]
        lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
        lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
        lib.OSMesaDestroyContext.argtypes = [ctypes.c_void_p]
        attrs = (ctypes.c_int * 9)(self._FORMAT, self._RGBA, self._PROFILE, self._CORE,
                                   self._MAJOR, REQUIRED_GL // 100, self._MINOR, (REQUIRED_GL // 10) % 10, 0)
        self._lib = lib
        self._ctx = lib.OSMesaCreateContextAttribs(attrs, None)
        if not self._ctx:
            raise GLUnavailable("OSMesa backend: could not create a GL "
                                f"{REQUIRED_GL // 100}.{(REQUIRED_GL // 10) % 10} core context")
        # OSMesa needs a colour buffer to make current; rendering goes to our own framebuffers.
        self._buffer = (ctypes.c_ubyte * 4)()
        if not lib.OSMesaMakeCurrent(self._ctx, self._buffer, 0x1401, 1, 1):
            raise GLUnavailable("OSMesa backend: OSMesaMakeCurrent failed")

    def __enter__(self):
        self._lib.OSMesaMakeCurrent(self._ctx, self._buffer, 0x1401, 1, 1)
        return self

    def __exit__(self, *exc) -> None:
        self._lib.OSMesaMakeCurrent(None, None, 0, 0, 0)   # release: see create_context

    def load_opengl_function(self, name: str) -> int:
        return self._lib.OSMesaGetProcAddress(name.encode()) or 0

    def release(self) -> None:
        if self._ctx:
            self._lib.OSMesaDestroyContext(self._ctx)
            self._ctx = None


def _create(backend: str, device_index: int) -> moderngl.Context:
    if backend == "egl":
        try:
            return moderngl.create_standalone_context(backend="egl", require=REQUIRED_GL, device_index=device_index)
        except Exception as exc:  # glcontext raises bare Exceptions for a missing libEGL or device
            raise GLUnavailable(
                f"EGL backend: {str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__}") from exc
    if backend == "osmesa":
        loader = _OSMesaLoader()
        try:
            ctx = moderngl.create_context(context=loader, standalone=True, require=REQUIRED_GL)
        except Exception as exc:
            loader.release()
            raise GLUnavailable(f"OSMesa backend: {exc}") from exc
        ctx.extra = {"gl_function": loader.load_opengl_function}
        return ctx
    raise GLUnavailable(f"unknown backend {backend!r}; allowed: {', '.join(BACKENDS)}")


def create_context(backend: str = "auto", device_index: int = 0) -> moderngl.Context:
    """A standalone GL 4.5 core context. 'auto' tries EGL, then OSMesa."""
    if backend not in BACKENDS:
        raise GLUnavailable(f"unknown backend {backend!r}; allowed: {', '.join(BACKENDS)}")
    if backend == "osmesa" and device_index != 0:
        raise GLUnavailable(f"device index {device_index}: OSMesa renders on the CPU and has one device, index 0")
    # A device index beyond 0 names an EGL device: falling back to OSMesa would ignore it.
    order = (("egl", "osmesa") if backend == "auto" and device_index == 0
             else ("egl",) if backend == "auto" else (backend,))
    failures = []
    for name in order:
        try:
            ctx = _create(name, device_index)
        except GLUnavailable as exc:
            if "device index" in str(exc):   # the driver works; the device does not exist
                raise GLUnavailable(f"{exc} (--device-index counts EGL devices from 0)") from None
            failures.append(str(exc))
            continue
        # Set up, then leave no context current: OSMesa and Mesa's EGL driver share libglapi's
        # current-context slot, and EGL skips a make-current it thinks is a no-op, so a context
        # left current by its creation got the GL calls meant for another (found by `sdfpbr
        # stress`). Every use of a context enters it (`with ctx:`).
        with ctx:
            ctx.enable_direct(GL_TEXTURE_CUBE_MAP_SEAMLESS)  # filter across cubemap faces
        ctx.extra = {"backend": name, "gl_function": (ctx.extra or {}).get("gl_function") or _egl_loader()}
        return ctx
    raise GLUnavailable("no OpenGL context: " + "; ".join(failures) + f"; {INSTALL_HINT}")


def _egl_loader():
    """A loader of the GL entry points moderngl does not wrap, for an EGL context."""
    # The libEGL glcontext loaded (same search, same override); eglGetProcAddress gives core
    # GL entry points too (EGL 1.5, EGL_KHR_get_all_proc_addresses: Mesa and NVIDIA).
    name = os.environ.get("GLCONTEXT_LINUX_LIBEGL") or ctypes.util.find_library("EGL")
    try:
        egl = ctypes.CDLL(name)
    except (OSError, TypeError):
        return None
    egl.eglGetProcAddress.restype = ctypes.c_void_p
    egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    return lambda function: egl.eglGetProcAddress(function.encode()) or 0


_GL_TEXTURE0, _GL_TEXTURE_2D, _GL_TEXTURE_CUBE_MAP, _GL_CUBE_FACE0 = 0x84C0, 0x0DE1, 0x8513, 0x8515
_GL_BASE_LEVEL, _GL_MAX_LEVEL, _GL_RGBA32F, _GL_RGBA, _GL_FLOAT = 0x813C, 0x813D, 0x8814, 0x1908, 0x1406
_GL_UNSIGNED_BYTE = 0x1401


class _TexImage:
    """glTexImage2D and what binding a texture for it takes, from the context's loader (the
    entry points moderngl does not wrap); None where no loader answers."""

    @classmethod
    def of(cls, ctx: moderngl.Context) -> "_TexImage | None":
        load = (ctx.extra or {}).get("gl_function")
        names = ("glActiveTexture", "glBindTexture", "glTexParameteri", "glTexImage2D")
        addresses = [load(f) if load else 0 for f in names]
        return cls(ctx, addresses) if all(addresses) else None

    def __init__(self, ctx: moderngl.Context, addresses: list[int]):
        self.ctx = ctx
        self.active = ctypes.CFUNCTYPE(None, ctypes.c_uint)(addresses[0])
        self.bind = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint)(addresses[1])
        self.parameter = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint, ctypes.c_int)(addresses[2])
        self.image = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                      ctypes.c_int, ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p)(addresses[3])

    def bound(self, target: int, texture) -> "_TexImage":
        self.active(_GL_TEXTURE0 + self.ctx.default_texture_unit)   # where moderngl binds a texture it edits
        self.bind(target, texture.glo)
        return self

    def levels(self, target: int, count: int) -> None:
        self.parameter(target, _GL_BASE_LEVEL, 0)
        self.parameter(target, _GL_MAX_LEVEL, count - 1)


def allocate_cube_levels(ctx: moderngl.Context, cube: moderngl.TextureCube, levels: int) -> None:
    """Give an RGBA32F cube levels 0 .. levels - 1, contents undefined, for the caller to write.

    moderngl allocates a chain only through build_mipmaps, which filters level 0 down; on
    llvmpipe the first such call of a process compiles a blit shader (~110-170 ms of a cold
    chart). Allocating with glTexImage2D costs nothing; build_mipmaps stays the fallback where
    no loader answers."""
    gl = _TexImage.of(ctx)
    if gl is None:
        cube.build_mipmaps(0, levels - 1)
        return
    size = cube.size[0]
    gl.bound(_GL_TEXTURE_CUBE_MAP, cube)
    for level in range(1, levels):
        s = max(1, size >> level)
        for face in range(6):
            gl.image(_GL_CUBE_FACE0 + face, level, _GL_RGBA32F, s, s, 0, _GL_RGBA, _GL_FLOAT, None)
    gl.levels(_GL_TEXTURE_CUBE_MAP, levels)


def upload_cube_levels(ctx: moderngl.Context, cube: moderngl.TextureCube, levels: list) -> bool:
    """Give an RGBA32F cube the levels ``levels`` ((6, s, s, 4) float32 arrays, faces in GL
    order, row 0 first, GL's level sizes) as they are. moderngl writes a cube's level 0 only;
    without this the IBL cache's chains were uploaded as 2D arrays and copied into the cube
    level by level by a compute shader (a gallery build: ~180 dispatches). False where no loader
    answers: then the caller copies them."""
    import numpy as np
    gl = _TexImage.of(ctx)
    if gl is None:
        return False
    gl.bound(_GL_TEXTURE_CUBE_MAP, cube)
    for level, data in enumerate(levels):
        data = np.ascontiguousarray(data, np.float32)   # rows of 16-byte texels: any unpack alignment holds
        for face in range(6):
            gl.image(_GL_CUBE_FACE0 + face, level, _GL_RGBA32F, data.shape[2], data.shape[1], 0, _GL_RGBA, _GL_FLOAT,
                     data[face].ctypes.data)
    gl.levels(_GL_TEXTURE_CUBE_MAP, len(levels))
    return True


def upload_levels(ctx: moderngl.Context, texture: moderngl.Texture, levels: list, internal_format: int) -> bool:
    """Give an RGBA8 2D texture (level 0 already in it) the levels 1.. ``levels`` (uint8
    (h, w, 4) arrays, GL's level sizes) as they are, instead of build_mipmaps' filtering (on
    llvmpipe a blit shader compiled per format in every process: 0.1 s a map). False where no
    loader answers: then the caller builds them."""
    gl = _TexImage.of(ctx)
    if gl is None:
        return False
    gl.bound(_GL_TEXTURE_2D, texture)
    for k, level in enumerate(levels, start=1):
        data = level if level.flags.c_contiguous else level.copy()   # rows of 4-byte texels: any unpack alignment holds
        gl.image(_GL_TEXTURE_2D, k, internal_format, data.shape[1], data.shape[0], 0, _GL_RGBA, _GL_UNSIGNED_BYTE,
                 data.ctypes.data)
    gl.levels(_GL_TEXTURE_2D, len(levels) + 1)
    return True


def renderer_string(ctx: moderngl.Context) -> str:
    with ctx:   # ctx.info calls glGetString, which answers "" unless the context is current
        return f"{ctx.info['GL_RENDERER']} | {ctx.info['GL_VERSION']}"


@dataclass(frozen=True)
class BackendReport:
    backend: str
    ok: bool
    vendor: str = ""
    renderer: str = ""
    version: str = ""
    error: str = ""


def doctor(device_index: int = 0) -> list[BackendReport]:
    """Try every backend; report what each gives or why it failed."""
    reports = []
    for name in ("egl", "osmesa"):
        try:
            ctx = _create(name, device_index)
        except GLUnavailable as exc:
            reports.append(BackendReport(name, False, error=str(exc)))
            continue
        with ctx:
            info = ctx.info
        reports.append(BackendReport(name, True, info["GL_VENDOR"], info["GL_RENDERER"], info["GL_VERSION"]))
        ctx.release()
    return reports
