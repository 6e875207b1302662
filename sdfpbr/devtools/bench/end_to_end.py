"""`sdfpbr bench --end-to-end`: what a chart costs around its draw, each figure beside the
target it is held to. Measured in one run, reported, never asserted.

- api: a warm `sdfpbr.chart()` at the bench size against the chart's draws alone (prepasses and
  chart program, `timing.time_chart`), interleaved in one process. A chart drawn before reads
  its prepasses from the disk cache, so the call can cost less than its draws.
- start: fresh `sdfpbr chart` processes of the default chart (`cold.cold_times`).
- gallery: `sdfpbr build CHARTS` into an empty folder with an empty sdfpbr cache (everything
  baked and rendered), again with only the bakes kept (its images, prepasses, labels and FLIP
  maps cleared), then once more with nothing changed. Mesa's shader cache as it is.
- animation: the peak memory of `sdfpbr chart --frames N --orbit light -o a.webp` against one
  chart's, and how far it grew sdfpbr's cache against one environment bake (the chart's).
- big: the peak memory of one `sdfpbr chart --size 8192x8192` (no HDR or AOVs asked).
"""
from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from ...cache import cache_entries, clear
from ...errors import SdfpbrError
from .cold import cold_times
from .suite import BenchConfig, scene_overrides, scene_spec
from .timing import time_chart, timer_query_measures_execution

# The targets (issue 11), and what each is measured on.
API_OVERHEAD_GPU_MS = 15.0          # a hardware GPU: the call's time above its draws
API_OVERHEAD_SOFTWARE_SHARE = 0.25  # llvmpipe: the same, as a share of the draws
START_MESA_WARM_S = 0.6             # `sdfpbr chart`, Mesa's shader cache warm (sdfpbr's too)
START_MESA_COLD_S = 1.0             # Mesa's cache off, sdfpbr's filled
GALLERY_COLD_S = 10.0               # the bakes kept, every image rendered
GALLERY_UNCHANGED_S = 0.5
ANIMATION_FRAMES = 360
ANIMATION_MEMORY_RATIO = 1.5        # peak memory against one chart's
BIG_CHART_PX = 8192
BIG_CHART_PEAK_GB = 1.5
API_ROUNDS = 7                      # calls either side of as many timed frames

# What a gallery build keeps per image (cleared for "the bakes kept"), as cache kinds.
IMAGE_KINDS = ("build", "prepasses", "labels", "flip")


@dataclass
class Figure:
    name: str
    value: float | None
    unit: str
    target: str
    met: bool | None
    detail: str

    def row(self) -> dict:
        return dict(vars(self))


@dataclass
class Process:
    seconds: float
    peak_bytes: int | None   # None where the platform does not report a child's peak memory


# A process's peak memory, as Linux counts it, starts at what its parent held when it forked
# (the copied or shared address space's high-water mark survives exec): every child of this
# bench, which holds charts, would read at least the bench's own size. So each command runs
# under a small launcher of its own, which times it and reads its rusage (os.wait4); the
# launcher holds little beyond the interpreter.
LAUNCHER = """
import json, os, subprocess, sys, time
err = open(sys.argv[1], "wb")
start = time.perf_counter()
proc = subprocess.Popen(sys.argv[2:], stdout=subprocess.DEVNULL, stderr=err)
if hasattr(os, "wait4"):
    _, status, usage = os.wait4(proc.pid, 0)
    code, peak = os.waitstatus_to_exitcode(status), usage.ru_maxrss * (1 if sys.platform == "darwin" else 1024)
else:
    code, peak = proc.wait(), None
proc.returncode = code
print(json.dumps([time.perf_counter() - start, code, peak]))
"""


def run_process(args: list[str], env: dict | None = None) -> Process:
    """Run `python -m sdfpbr ARGS` under the launcher: its wall time and peak resident memory."""
    import json
    with tempfile.NamedTemporaryFile(prefix="sdfpbr-e2e-", suffix=".err", delete=False) as f:
        err_path = f.name
    try:
        cmd = [sys.executable, "-c", LAUNCHER, err_path, sys.executable, "-m", "sdfpbr", *args]
        out = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if out.returncode != 0:
            raise SdfpbrError(f"bench: the launcher of `sdfpbr {' '.join(args)}` failed: "
                              f"{(out.stderr.strip().splitlines() or ['no message'])[-1]}")
        seconds, code, peak = json.loads(out.stdout)
        if code != 0:
            lines = Path(err_path).read_text(errors="replace").strip().splitlines() or ["no message"]
            raise SdfpbrError(f"bench: `sdfpbr {' '.join(args)}` failed: {lines[-1]}")
    finally:
        os.unlink(err_path)
    return Process(seconds, peak)


def folder_bytes(root: Path) -> int:
    return sum(size for _, size, _ in cache_entries(root)) if root.exists() else 0


def _env(cache_dir: Path) -> dict:
    # Uncapped: a cap would evict what the figure measures the growth of.
    return dict(os.environ, SDFPBR_CACHE_DIR=str(cache_dir), SDFPBR_CACHE_MAX="none")


def api_figure(session, cfg: BenchConfig, log) -> Figure:
    import sdfpbr
    spec = scene_spec("default", cfg)

    def calls(n: int) -> list[float]:
        out = []
        for _ in range(n):
            start = time.perf_counter()
            sdfpbr.chart(width=cfg.width, height=cfg.height, backend=cfg.backend, session=session)
            out.append(time.perf_counter() - start)
        return out

    calls(2)   # programs, bakes and prepasses in place: the warm call
    before = calls(API_ROUNDS)
    draws = time_chart(session, spec, API_ROUNDS, 1, compile_time=False).draw.median_ms
    api_ms = 1000 * statistics.median(before + calls(API_ROUNDS))
    over = api_ms - draws
    detail = (f"call {api_ms:.1f} ms, draws {draws:.1f} ms "
              f"(medians of {2 * API_ROUNDS} calls either side of {API_ROUNDS} frames)")
    log(f"api: warm chart() {api_ms:.1f} ms, its draws {draws:.1f} ms")
    name = f"warm chart() {cfg.width}x{cfg.height}, above its draws"
    if timer_query_measures_execution(session.ctx):   # a hardware GPU
        return Figure(name, over, "ms", f"<= {API_OVERHEAD_GPU_MS:g} ms", over <= API_OVERHEAD_GPU_MS, detail)
    return Figure(name, over / draws, "x the draws", f"<= {API_OVERHEAD_SOFTWARE_SHARE:g}x the draws",
                  over <= API_OVERHEAD_SOFTWARE_SHARE * draws, detail)


def start_figures(cfg: BenchConfig, log) -> list[Figure]:
    cold, cold_filled, start = cold_times(scene_overrides("default"), "default", cfg)
    log(f"start: {cold:.2f} s empty caches, {cold_filled:.2f} s sdfpbr's filled, {start:.2f} s both warm")
    size = f"{cfg.width}x{cfg.height}"
    return [Figure(f"`sdfpbr chart` {size}, Mesa's cache warm", start, "s", f"<= {START_MESA_WARM_S:g} s",
                   start <= START_MESA_WARM_S, "sdfpbr's cache filled; median of 3 processes"),
            Figure(f"`sdfpbr chart` {size}, Mesa's cache off", cold_filled, "s", f"<= {START_MESA_COLD_S:g} s",
                   cold_filled <= START_MESA_COLD_S, f"sdfpbr's cache filled (both empty: {cold:.2f} s)")]


def gallery_figures(charts: Path, log) -> list[Figure]:
    with tempfile.TemporaryDirectory(prefix="sdfpbr-e2e-") as tmp:
        cache, env = Path(tmp) / "cache", _env(Path(tmp) / "cache")
        first = run_process(["build", str(charts), "-o", str(Path(tmp) / "a"), "-q"], env)
        for kind in IMAGE_KINDS:
            clear(cache, kind)
        baked = run_process(["build", str(charts), "-o", str(Path(tmp) / "b"), "-q"], env)
        same = run_process(["build", str(charts), "-o", str(Path(tmp) / "b"), "-q"], env)
    count = len(list(charts.glob("*.toml")))
    log(f"gallery: {first.seconds:.1f} s from nothing, {baked.seconds:.1f} s with the bakes, "
        f"{same.seconds:.2f} s unchanged")
    return [Figure(f"`sdfpbr build {charts.name}` ({count} entries), bakes kept", baked.seconds, "s",
                   f"<= {GALLERY_COLD_S:g} s", baked.seconds <= GALLERY_COLD_S,
                   f"every image rendered; from an empty cache {first.seconds:.1f} s"),
            Figure(f"`sdfpbr build {charts.name}`, nothing changed", same.seconds, "s",
                   f"<= {GALLERY_UNCHANGED_S:g} s", same.seconds <= GALLERY_UNCHANGED_S,
                   "a process, start-up included")]


def animation_figures(cfg: BenchConfig, frames: int, log) -> list[Figure]:
    size = ["--size", f"{cfg.width}x{cfg.height}"]
    with tempfile.TemporaryDirectory(prefix="sdfpbr-e2e-") as tmp:
        cache, env = Path(tmp) / "cache", _env(Path(tmp) / "cache")
        one = run_process(["chart", *size, "-o", str(Path(tmp) / "c.png")], env)
        bake = folder_bytes(cache / "ibl")
        before = folder_bytes(cache)
        anim = run_process(["chart", *size, "--frames", str(frames), "--orbit", "light",
                            "-o", str(Path(tmp) / "a.webp")], env)
        grew = folder_bytes(cache) - before
        webp = (Path(tmp) / "a.webp").stat().st_size
    if one.peak_bytes is None or anim.peak_bytes is None:
        return [Figure(f"{frames}-frame orbit, peak memory", None, "", "", None, "no peak memory on this platform")]
    ratio = anim.peak_bytes / one.peak_bytes
    log(f"animation: {frames} frames in {anim.seconds:.1f} s, peak {anim.peak_bytes / 2**20:.0f} MB "
        f"(one chart {one.peak_bytes / 2**20:.0f} MB), cache +{grew / 2**20:.1f} MB")
    mb = lambda n: f"{n / 2**20:.1f} MB"   # noqa: E731
    return [Figure(f"{frames}-frame light orbit (WebP), peak memory", ratio, "x one chart's",
                   f"<= {ANIMATION_MEMORY_RATIO:g}x", ratio <= ANIMATION_MEMORY_RATIO,
                   f"{mb(anim.peak_bytes)} against {mb(one.peak_bytes)}; {anim.seconds:.1f} s, {mb(webp)} written"),
            Figure(f"{frames}-frame light orbit, cache growth", grew / 2**20, "MB", f"<= one bake ({mb(bake)})",
                   grew <= bake, "after one chart of the same spec")]


def big_chart_figure(size: int, log) -> Figure:
    with tempfile.TemporaryDirectory(prefix="sdfpbr-e2e-") as tmp:
        big = run_process(["chart", "--size", f"{size}x{size}", "-o", str(Path(tmp) / "big.png")],
                          _env(Path(tmp) / "cache"))
    if big.peak_bytes is None:
        return Figure(f"{size}x{size} chart, peak memory", None, "", "", None, "no peak memory on this platform")
    gb = big.peak_bytes / 2**30
    log(f"big: {size}x{size} in {big.seconds:.1f} s, peak {gb:.2f} GB")
    return Figure(f"{size}x{size} chart, peak memory", gb, "GB", f"<= {BIG_CHART_PEAK_GB:g} GB",
                  gb <= BIG_CHART_PEAK_GB, f"{big.seconds:.1f} s, caches empty")


def end_to_end_figures(session, cfg: BenchConfig, charts: Path | None = Path("charts"),
                       frames: int = ANIMATION_FRAMES, big_size: int = BIG_CHART_PX) -> list[Figure]:
    """Every figure above at the bench's size; the gallery where ``charts`` is a folder."""
    log = cfg.log or (lambda line: None)
    figures = [api_figure(session, cfg, log), *start_figures(cfg, log)]
    if charts is not None and charts.is_dir():
        figures += gallery_figures(charts, log)
    else:
        figures.append(Figure("gallery build", None, "", "", None, f"no chart folder at {charts}"))
    figures += animation_figures(cfg, frames, log)
    figures.append(big_chart_figure(big_size, log))
    return figures


def format_figures(figures: list[Figure]) -> str:
    lines = [f"{'figure':58s} {'value':>10s}  {'target':24s} met   detail"]
    for f in figures:
        value = "-" if f.value is None else f"{f.value:.3g} {f.unit}"
        met = "-" if f.met is None else ("yes" if f.met else "NO")
        lines.append(f"{f.name:58s} {value:>10s}  {f.target:24s} {met:5s} {f.detail}")
    return "\n".join(lines)
