"""Cold starts: wall time of fresh ``python -m sdfpbr chart`` processes with Mesa's shader
cache off, with an empty and then a filled sdfpbr disk cache; and with both caches warm (a
user's every later run)."""
from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time

from ...errors import SdfpbrError, SpecError
from ...spec.chart_spec import make_spec
from ...spec.fields import spec_to_flags, spec_to_toml
from .suite import BenchConfig


def cli_flags(overrides: dict, preset: str, width: int, height: int, backend: str, workdir: str) -> list[str]:
    """`sdfpbr chart` flags for a scene's overrides, written by the field table; a scene whose
    lights have no flag is written to a spec file in ``workdir`` and read with --spec."""
    spec = make_spec(width=width, height=height, quality=preset, backend=backend, **overrides)
    try:
        return spec_to_flags(spec)
    except SpecError:
        path = os.path.join(workdir, "scene.toml")
        with open(path, "w", encoding="utf-8") as f:
            f.write(spec_to_toml(spec))
        return ["--spec", path]


# A result row's cold-start columns, in the order cold_times returns them (None: not run).
COLD_COLUMNS = ("cold_s", "cold_warm_cache_s", "start_s")

# Fresh processes timed with both caches warm; their median is reported (a shared host's start-up
# swings by a quarter from one minute to the next). Fewer when the run asks for fewer repeats.
START_RUNS = 3


def cold_chart_seconds(flags: list[str], cache_dir: str, workdir: str, mesa_cache_dir: str | None = None) -> float:
    """Wall time of a fresh `python -m sdfpbr chart` with Mesa's shader cache off, or kept in
    ``mesa_cache_dir``."""
    mesa = ({"MESA_SHADER_CACHE_DISABLE": "true"} if mesa_cache_dir is None
            else {"MESA_SHADER_CACHE_DISABLE": "false", "MESA_SHADER_CACHE_DIR": mesa_cache_dir})
    env = dict(os.environ, SDFPBR_CACHE_DIR=cache_dir, **mesa)
    cmd = [sys.executable, "-m", "sdfpbr", "chart", "-o", os.path.join(workdir, "chart.png"), *flags]
    start = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["no message"])[-1]
        raise SdfpbrError(f"bench: cold `sdfpbr chart {' '.join(flags)}` failed: {last}")
    return seconds


def cold_times(overrides: dict, preset: str, cfg: BenchConfig) -> tuple[float, float, float]:
    """(empty sdfpbr cache, filled sdfpbr cache) seconds, both with Mesa's cache off; then the
    median of START_RUNS starts (at most cfg.repeats) with both caches warm (Mesa's in a
    directory of its own, filled by an untimed run first)."""
    with tempfile.TemporaryDirectory(prefix="sdfpbr-bench-") as tmp:
        flags = cli_flags(overrides, preset, cfg.width, cfg.height, cfg.backend, tmp)
        cache, mesa = os.path.join(tmp, "cache"), os.path.join(tmp, "mesa")
        cold = cold_chart_seconds(flags, cache, tmp)
        warm = cold_chart_seconds(flags, cache, tmp)
        cold_chart_seconds(flags, cache, tmp, mesa)
        runs = min(START_RUNS, cfg.repeats)
        start = statistics.median(cold_chart_seconds(flags, cache, tmp, mesa) for _ in range(runs))
    return cold, warm, start
