"""One GL context per backend for the whole session (moderngl's own suite does the same), a
private disk cache, and the one place that knows which GL backends and optional extras this
machine has.

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


@pytest.fixture(scope="session")
def cache_dir(tmp_path_factory):
    path = tmp_path_factory.mktemp("cache")
    os.environ["SDFPBR_CACHE_DIR"] = str(path)   # subprocesses of the CLI tests share it
    return path


@pytest.fixture(scope="session")
def session(cache_dir):
    reason = missing_backend("egl")
    if reason:
        pytest.skip(reason)
    return Session(backend_context("egl")[0], ArrayCache(cache_dir))


@pytest.fixture(scope="session")
def osmesa_session(cache_dir):
    reason = missing_backend("osmesa")
    if reason:
        pytest.skip(reason)
    return Session(backend_context("osmesa")[0], ArrayCache(cache_dir))


@pytest.fixture
def ctx(session):
    with session.ctx:
        session.ctx.clear_errors()
        yield session.ctx
