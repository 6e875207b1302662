"""One GL context per backend, shared by the test modules and made fresh when it has grown
large (see FRESH_CONTEXT_ABOVE), the run's private disk cache, shared by the xdist workers,
and the one place that knows which GL backends and optional extras this machine has.

A test that needs a backend or an extra says so with a marker and is skipped, with the reason,
where it is absent (an NVIDIA machine has EGL but no OSMesa; a bare install has no extras):

    @pytest.mark.requires_backend("osmesa")
    @pytest.mark.requires_extra("imageio_ffmpeg")

Each backend and extra is probed once per session, when the first test that needs it runs.
The ``session`` / ``osmesa_session`` fixtures use the probed contexts and skip the same way.
"""
import functools
import importlib
import os

import pytest

import sdfpbr.extras
from sdfpbr.cache import ArrayCache
from sdfpbr.errors import GLUnavailable
from sdfpbr.extras import install_command
from sdfpbr.gpu.gl import create_context
from sdfpbr.gpu.session import Session

# Mesa's llvmpipe runs LLVM's optimisation passes on every program it compiles; the tests' small
# images do not pay them back. Without them (GALLIVM_PERF=nopt) the suite took 743 s instead of
# 841 s from a cold shader cache on 2 cores, and the default chart's PNG was the same bytes.
# Set before the first context loads the driver (importing sdfpbr creates none); subprocesses
# inherit it; other drivers ignore it.
os.environ.setdefault("GALLIVM_PERF", "nopt")

# The optional extras of pyproject.toml, by the module a test imports (directly or through the
# code or subprocess it runs), with what to install.
EXTRAS = {
    **{module: f"{package} (the {extra!r} extra: {install_command(extra)})"
       for extra, (module, package) in sdfpbr.extras.EXTRAS.items()},
    "flip_evaluator": f"flip-evaluator (the 'test' extra: {install_command('test')})",
    "pygltflib": f"pygltflib, which the tests write glTF assets with (the 'test' extra: {install_command('test')})",
}

# What must import for the extra to work, where that is more than its top module: an image with
# a stray 'sphinx' folder on its path imports "sphinx" but has no builder to run.
PROBE = {"sphinx": "sphinx.cmd.build"}


@functools.cache
def backend_context(name: str):
    """(context, "") for a GL backend that starts here, else (None, why not); once per session."""
    try:
        return create_context(name), ""
    except GLUnavailable as exc:
        return None, str(exc)


def missing_backend(name: str) -> str | None:
    ctx, why = backend_context(name)
    return None if ctx is not None else f"needs the {name} GL backend, absent here: {why}"


@functools.cache
def missing_extra(module: str) -> str | None:
    """Why the optional extra providing ``module`` is unusable here, or None."""
    if module not in EXTRAS:
        raise ValueError(f"requires_extra({module!r}): not an extra of sdfpbr; known: {', '.join(EXTRAS)}")
    try:
        mod = importlib.import_module(PROBE.get(module, module))
        if module == "imageio_ffmpeg":
            mod.get_ffmpeg_exe()   # the package without its ffmpeg binary cannot write MP4 either
    except Exception as exc:   # ImportError, or the extra's own "not found" error
        return f"needs the optional extra {EXTRAS[module]}: {type(exc).__name__}: {exc}"
    return None


def pytest_configure(config):
    config.addinivalue_line("markers", "requires_backend(name, ...): skip, with the reason, unless each GL "
                                       "backend ('egl', 'osmesa') can create a context here")
    config.addinivalue_line("markers", "requires_extra(module, ...): skip, with the reason, unless each "
                                       f"optional extra imports here; modules: {', '.join(EXTRAS)}")


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    for mark in item.iter_markers("requires_backend"):
        for name in mark.args:
            reason = missing_backend(name)
            if reason:
                pytest.skip(reason)
    for mark in item.iter_markers("requires_extra"):
        for module in mark.args:
            reason = missing_extra(module)
            if reason:
                pytest.skip(reason)


@pytest.fixture(scope="session", autouse=True)
def cache_dir(tmp_path_factory):
    """The run's own disk cache, for every test (autouse: a CLI subprocess never writes to the
    user's ~/.cache). Bakes (IBL, DFG, prepasses) are most of the suite's time, so the xdist
    workers share one cache: a bake one worker made, the others read. Workers may write one
    key at once: entries are written whole and renamed into place (test_concurrency)."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        path = tmp_path_factory.getbasetemp().parent / "cache"   # the run's folder, above each worker's
        path.mkdir(exist_ok=True)
    else:
        path = tmp_path_factory.mktemp("cache")
    os.environ["SDFPBR_CACHE_DIR"] = str(path)   # subprocesses of the CLI tests share it
    return path


# A GL context keeps every program it compiled until the context goes (llvmpipe's code for the
# chart's shaders: 5-25 MB a program here); one context for the whole run grew a worker to
# 3.7 GB. So a test module starts on a fresh context once its worker holds more than this (what
# the next modules use is compiled again, from Mesa's disk cache: well under a second each).
# Every module checks, GL or not: checked only where a module asked for a session, a worker
# carried a module's 2.4 GB through the modules after it that draw nothing.
FRESH_CONTEXT_ABOVE = 1 << 30   # bytes resident


def resident_bytes() -> int:
    """This process's resident memory (0 where /proc cannot say: never a fresh context)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError):
        return 0


class SharedSessions:
    """Per backend, the Session test modules share and its siblings (the same context and
    cache, other settings); made again on a fresh context past FRESH_CONTEXT_ABOVE."""

    def __init__(self):
        self.sessions: dict[str, Session | None] = {}   # None: released, the next is a fresh context
        self.siblings: dict[tuple, Session] = {}

    def get(self, backend: str, cache_dir) -> Session:
        reason = missing_backend(backend)
        if reason:
            pytest.skip(reason)
        current = self.sessions.get(backend)
        if current is None:
            ctx = backend_context(backend)[0] if backend not in self.sessions else create_context(backend)
            current = self.sessions[backend] = Session(ctx, ArrayCache(cache_dir))
        return current

    def release(self) -> None:
        """Every backend's session goes, its context and its siblings' objects with it; the
        next get() makes a fresh context."""
        for backend, current in self.sessions.items():
            if current is not None:
                current.release()
                self.sessions[backend] = None
        self.siblings = {}
        _release_freed_heap()

    def sibling(self, backend: str, base: Session, settings: dict) -> Session:
        key = (backend, *sorted(settings.items()))
        if key not in self.siblings:
            self.siblings[key] = Session(base.ctx, base.cache, **settings)
        return self.siblings[key]


def _release_freed_heap() -> None:
    """Hand the heap a released context freed back to the system (glibc keeps it otherwise),
    so the other workers and the CLI tests' processes may use it."""
    import ctypes
    try:
        ctypes.CDLL(None).malloc_trim(0)
    except (AttributeError, OSError):   # not glibc
        pass


SHARED = SharedSessions()


@pytest.fixture(scope="module", autouse=True)
def fresh_context_when_large():
    """Before each module's first test (ahead of its sessions): a fresh context where the
    worker holds more than FRESH_CONTEXT_ABOVE."""
    if resident_bytes() > FRESH_CONTEXT_ABOVE:
        SHARED.release()


@pytest.fixture(scope="module")
def session(cache_dir):
    return SHARED.get("egl", cache_dir)


@pytest.fixture(scope="module")
def sibling(session):
    """sibling(**settings): a Session on ``session``'s context and cache with other settings
    (chart_shader, tile), one per settings while that context lasts. A Session keeps what it
    uploads on its context until the context goes, so tests share these rather than make a
    Session each; a test whose claim is about a fresh Session makes its own."""
    def get(**settings):
        settings = {k: v for k, v in settings.items() if v is not None}   # None: Session's default
        return SHARED.sibling("egl", session, settings)
    return get


@pytest.fixture(scope="module")
def osmesa_session(cache_dir):
    return SHARED.get("osmesa", cache_dir)


@pytest.fixture
def ctx(session):
    with session.ctx:
        session.ctx.clear_errors()
        yield session.ctx
