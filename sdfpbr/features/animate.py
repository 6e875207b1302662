"""Animated charts: the key light or the camera orbits the sphere grid.

Frames are ordinary chart renders (labeled like ``chart()``), so frame 0 is the still chart of
the same spec. Written as GIF or WebP (Pillow, looping forever) or MP4 (imageio-ffmpeg, extra
``video``), chosen by the output suffix, through a temporary file renamed into place.
"""
from __future__ import annotations

import importlib
import math
import sys
from contextlib import nullcontext
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import SpecError
from ..image.animation_writer import AnimationWriter
from ..image.io import check_writable
from ..image.sheet import assemble, sheet_text_size
from ..gpu.prepasses import PREPASS_KIND
from ..gpu.session import default_session
from ..progress import Progress
from ..spec.chart_spec import ChartSpec, make_spec
from ..spec.presets import DEFAULT_FPS, ORBITS
from ..image.chart_labels import label
from ..spec.chart_spec import as_spec
from .compare import bug_pair, chart_panel, render_chart, sheet_page

__all__ = ["Animation", "animate", "animate_compare", "orbit_specs", "check_animation_output",
           "write_animation", "ANIMATION_SUFFIXES", "ORBITS"]

ANIMATION_SUFFIXES = (".gif", ".webp", ".mp4")
MAX_FRAMES = 3600


@dataclass
class Animation:
    frames: np.ndarray | None           # (N, H, W, 4) uint8 sRGB; None when streamed to a file only
    fps: float
    specs: list[ChartSpec] = field(default_factory=list)   # one per frame (pairs: correct, buggy, ...)
    count: int = 0                      # frames rendered
    size: tuple[int, int] = (0, 0)      # (width, height) of a frame

    def save(self, path: str | Path) -> None:
        if self.frames is None:
            raise SpecError("this animation was streamed to its file without keeping frames; "
                            "render it with keep_frames=True to save it again")
        check_animation_output(path, self.fps)
        write_animation(path, self.frames, self.fps)


# ---------------------------------------------------------------------------------------------
# Checks, made before any frame is rendered.

def _check_frames(frames) -> int:
    if isinstance(frames, bool) or not isinstance(frames, int) or not 1 <= frames <= MAX_FRAMES:
        raise SpecError(f"frames must be a whole number in [1, {MAX_FRAMES}], got {frames!r}")
    return frames


MIN_FPS, MAX_FPS = 0.1, 100.0   # a frame per 10 s at the slowest: every encoder's delay field holds it


def _check_fps(fps) -> float:
    if (isinstance(fps, bool) or not isinstance(fps, (int, float))
            or not (math.isfinite(fps) and MIN_FPS <= fps <= MAX_FPS)):
        raise SpecError(f"fps must be a number in [{MIN_FPS:g}, {MAX_FPS:g}], got {fps!r}")
    return float(fps)


def check_animation_output(path: str | Path, fps: float = DEFAULT_FPS, lossless: bool = False) -> Path:
    """Fail before rendering on a bad suffix, an unwritable place, a bad fps, a missing encoder
    or ``lossless`` asked of a container that has no such choice."""
    p = check_writable(path, ANIMATION_SUFFIXES, "output")
    _check_fps(fps)
    if lossless and p.suffix.lower() != ".webp":
        raise SpecError(f"--lossless stores WebP frames exactly; {p.suffix.lower()} has no lossless choice "
                        f"(GIF is always exact to its palette): leave it out or write .webp")
    if p.suffix.lower() == ".mp4":
        try:
            importlib.import_module("imageio_ffmpeg")   # only whether it imports matters
        except ImportError:
            from ..extras import missing_extra
            raise missing_extra("video", "writing .mp4", "or write .gif or .webp") from None
    return p


def orbit_specs(spec: ChartSpec, frames: int, orbit: str = "light") -> list[ChartSpec]:
    """One spec per frame, a full turn in ``frames`` steps starting at ``spec`` itself.

    light: the key light (the first directional light) turns about the vertical axis, so its
    elevation stays; camera: ``camera_azimuth`` advances from the spec's value by 360°."""
    frames = _check_frames(frames)
    if orbit not in ORBITS:
        raise SpecError(f"orbit {orbit!r} is not allowed; allowed: {', '.join(ORBITS)}")
    if orbit == "camera":
        return [spec] + [make_spec(spec, camera_azimuth=spec.camera_azimuth + 360.0 * i / frames)
                         for i in range(1, frames)]
    key = next((i for i, light in enumerate(spec.lights) if light.kind == "directional"), None)
    if key is None:
        raise SpecError("orbit light needs a directional (key) light in the spec; use orbit camera instead")
    out = [spec]
    for i in range(1, frames):
        angle = 2.0 * math.pi * i / frames
        c, s = math.cos(angle), math.sin(angle)
        x, y, z = spec.lights[key].direction
        light = replace(spec.lights[key], direction=(c * x + s * z, y, -s * x + c * z))
        lights = spec.lights[:key] + (light,) + spec.lights[key + 1:]
        out.append(make_spec(spec, lights=lights))
    return out


# ---------------------------------------------------------------------------------------------
# Rendering.

def _frames(specs: list, desc: str, enabled: bool | None, orbit: str):
    """``specs`` one by one, reporting progress; None: only on a terminal. A light orbit turns
    the key light (the first directional one) about the vertical: the cells stage's probe of
    each frame after the first is composed from the first's (Session.turning_light). Bakes made
    after the first frame are not written to the disk cache (2 MB a frame no later render reads),
    nor any frame's prepasses (they save a still chart's start; an animation's compile is spread
    over its frames): an animation grows the cache by its first frame's bakes at most."""
    first = specs[0][0] if isinstance(specs[0], tuple) else specs[0]
    session = default_session(first.backend, first.device_index)
    with Progress(len(specs), desc, "frames", enabled=sys.stderr.isatty() if enabled is None else enabled) as bar, \
            session.turning_light(0) if orbit == "light" else nullcontext():
        for i, spec in enumerate(specs):
            with session.cache.reading_only(None if i else (PREPASS_KIND,)):
                yield spec
            bar.update(1)


def _chart_frame(spec: ChartSpec) -> np.ndarray:
    return label(spec, render_chart(spec).result)   # labels need the camera only, no AOVs


def _stream(images, output: str | Path | None, fps: float, keep: bool | None, specs: list,
            lossless: bool = False) -> Animation:
    """Each image of ``images`` (an iterator that renders as it goes) to ``output``'s encoder as
    it comes, so memory stays flat in the frame count; the frames stacked only when ``keep``
    (default: when there is no output)."""
    keep = output is None if keep is None else keep
    kept, count, size = [], 0, (0, 0)
    writer = (AnimationWriter(output, fps, Path(output).suffix.lower(), lossless) if output is not None
              else nullcontext())
    with writer as w:
        for image in images:
            if w is not None:
                w.add(image)
            if keep:
                kept.append(image)
            count, size = count + 1, (image.shape[1], image.shape[0])
    return Animation(np.stack(kept) if keep else None, float(fps), specs, count, size)


def animate(spec: ChartSpec | str | Path | None = None, frames: int = 36, orbit: str = "light", *,
            output: str | Path | None = None, fps: float = DEFAULT_FPS, progress: bool | None = None,
            keep_frames: bool | None = None, lossless: bool = False) -> Animation:
    """Render ``frames`` charts of one orbit (see orbit_specs). With ``output`` (.gif, .webp or
    .mp4, checked before the first frame is rendered) each frame goes to the file as it is
    rendered and is not kept unless ``keep_frames``; without, the frames are returned.
    ``lossless``: WebP frames stored exactly (about 4x larger than the default lossy frames)."""
    spec = as_spec(spec, "spec")
    specs = orbit_specs(spec, frames, orbit)
    if output is not None:
        check_animation_output(output, fps, lossless)
    _check_fps(fps)
    images = (_chart_frame(s) for s in _frames(specs, f"orbit {orbit}", progress, orbit))
    return _stream(images, output, fps, keep_frames, specs, lossless)


def animate_compare(spec: ChartSpec | str | Path | None, bug_name: str, frames: int = 36, orbit: str = "light", *,
                    output: str | Path | None = None, fps: float = DEFAULT_FPS, progress: bool | None = None,
                    axes: bool | None = None, keep_frames: bool | None = None, lossless: bool = False) -> Animation:
    """The correct chart and the same chart with ``bug_name`` on, side by side, both orbiting
    in step; titled with the bug's name and summary, captioned with its explanation. Frames
    stream to ``output`` as in animate()."""
    spec = as_spec(spec, "spec")
    bug, correct, buggy = bug_pair(spec, bug_name)
    pairs = list(zip(orbit_specs(correct, frames, orbit), orbit_specs(buggy, frames, orbit)))
    if output is not None:
        check_animation_output(output, fps, lossless)
    _check_fps(fps)
    axes = correct.labels if axes is None else axes
    text_size = sheet_text_size(correct.height)
    page = sheet_page(correct)   # laid onto a backdrop: the frame's page is that colour too

    def images():
        for c, b in _frames(pairs, f"{bug.name} orbit {orbit}", progress, orbit):
            panels = [chart_panel("correct", render_chart(c), axes, text_size, page_srgb=page),
                      chart_panel(f"buggy: {bug.name}", render_chart(b), axes, text_size, page_srgb=page)]
            yield np.array(assemble([panels], title=f"{bug.name}: {bug.summary}", caption=bug.caption,
                                    text_size=text_size, page_srgb=page))
    return _stream(images(), output, fps, keep_frames, [s for pair in pairs for s in pair], lossless)


# ---------------------------------------------------------------------------------------------
# Writing.

def write_animation(path: str | Path, frames, fps: float = DEFAULT_FPS, lossless: bool = False) -> None:
    """Frames ((N, H, W, 4) uint8, or an iterable of (H, W, 4) frames, encoded as they come) to
    .gif / .webp (loop forever) or .mp4, atomically; ``lossless`` WebP on request."""
    suffix = Path(path).suffix.lower()
    if suffix not in ANIMATION_SUFFIXES:
        raise SpecError(f"output {path} must end in {' or '.join(ANIMATION_SUFFIXES)}")
    with AnimationWriter(path, fps, suffix, lossless) as writer:
        for frame in frames:
            writer.add(frame)


# ---------------------------------------------------------------------------------------------
# Command line: `sdfpbr chart --frames N` (cli.main.cmd_chart hands its spec over here).

def cmd_chart_animation(spec: ChartSpec, args) -> int:
    """The chart command's --frames: ``spec`` parsed from the chart flags, ``args`` for the
    outputs, frames, orbit, fps and -v."""
    import time
    if args.hdr or args.aov:
        raise SpecError("--hdr and --aov write single images; leave them out with --frames")
    orbit_specs(spec, args.frames, args.orbit)          # frames and orbit checked before rendering
    if args.output.lower().endswith(".png"):
        raise SpecError(f"--frames writes an animation: give -o NAME.gif, .webp or .mp4 (got {args.output})")
    check_animation_output(args.output, args.fps, args.lossless)
    start = time.perf_counter()
    animation = animate(spec, args.frames, args.orbit, output=args.output, fps=args.fps,
                        progress=True, lossless=args.lossless)
    if args.verbose:
        w, h = animation.size
        print(f"{args.output}: {animation.count} frames {w}x{h} at {args.fps:g} fps, "
              f"orbit {args.orbit}, {time.perf_counter() - start:.2f} s")
    return 0
