"""One GL context per backend for the whole session (moderngl's own suite does the same), a
private disk cache."""
import os

import pytest

from sdfpbr.cache import ArrayCache
from sdfpbr.gpu.gl import create_context
from sdfpbr.gpu.render import Renderer


@pytest.fixture(scope="session")
def cache_dir(tmp_path_factory):
    path = tmp_path_factory.mktemp("cache")
    os.environ["SDFPBR_CACHE_DIR"] = str(path)   # subprocesses of the CLI tests share it
    return path


@pytest.fixture(scope="session")
def renderer(cache_dir):
    return Renderer(create_context("egl"), ArrayCache(cache_dir))


@pytest.fixture(scope="session")
def osmesa_renderer(cache_dir):
    return Renderer(create_context("osmesa"), ArrayCache(cache_dir))


@pytest.fixture
def ctx(renderer):
    with renderer.ctx:
        renderer.ctx.clear_errors()
        yield renderer.ctx
