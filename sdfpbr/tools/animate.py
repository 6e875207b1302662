"""Animated charts: the key light or the camera orbits the sphere grid.

Frames are ordinary chart renders (labeled like ``chart()``), so frame 0 is the still chart of
the same spec. Written as GIF or WebP (Pillow, looping forever) or MP4 (imageio-ffmpeg, extra
``video``), chosen by the output suffix, through a temporary file renamed into place.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import SpecError
from ..files import atomic_path
from ..image.io import check_writable
from ..image.sheet import assemble, flatten, sheet_text_size
from ..progress import Progress
from ..spec.chart_spec import ChartSpec, make_spec
from ..image.chart_labels import label
from ..spec.chart_spec import as_spec
from .compare import bug_pair, chart_panel, render_chart

__all__ = ["Animation", "animate", "animate_compare", "orbit_specs", "check_animation_output",
           "write_animation", "ANIMATION_SUFFIXES", "ORBITS"]

ANIMATION_SUFFIXES = (".gif", ".webp", ".mp4")
ORBITS = ("light", "camera")
MAX_FRAMES = 3600
DEFAULT_FPS = 15.0


@dataclass
class Animation:
    frames: np.ndarray                  # (N, H, W, 4) uint8 sRGB
    fps: float
    specs: list[ChartSpec] = field(default_factory=list)   # one per frame (pairs: correct, buggy, ...)

    def save(self, path: str | Path) -> None:
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
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not (math.isfinite(fps) and MIN_FPS <= fps <= MAX_FPS):
        raise SpecError(f"fps must be a number in [{MIN_FPS:g}, {MAX_FPS:g}], got {fps!r}")
    return float(fps)


def check_animation_output(path: str | Path, fps: float = DEFAULT_FPS) -> Path:
    """Fail before rendering on a bad suffix, an unwritable place, a bad fps or a missing encoder."""
    p = check_writable(path, ANIMATION_SUFFIXES, "output")
    _check_fps(fps)
    if p.suffix.lower() == ".mp4":
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError:
            raise SpecError("writing .mp4 needs imageio-ffmpeg: pip install 'sdfpbr[video]' "
                            "(or write .gif or .webp)") from None
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

def _frames(specs: list, desc: str, enabled: bool | None):
    """``specs`` one by one, reporting progress; None: only on a terminal."""
    with Progress(len(specs), desc, "frames", enabled=sys.stderr.isatty() if enabled is None else enabled) as bar:
        for spec in specs:
            yield spec
            bar.update(1)


def _chart_frame(spec: ChartSpec) -> np.ndarray:
    return label(spec, render_chart(spec).result)   # labels need the camera only, no AOVs


def _stack(frames: list[np.ndarray]) -> np.ndarray:
    shapes = {f.shape for f in frames}
    if len(shapes) != 1:   # the layout depends only on text that does not change; guard anyway
        raise RuntimeError(f"animation frames differ in size: {sorted(shapes)}")
    return np.stack(frames)


def animate(spec: ChartSpec | str | Path | None = None, frames: int = 36, orbit: str = "light", *,
            output: str | Path | None = None, fps: float = DEFAULT_FPS, progress: bool | None = None) -> Animation:
    """Render ``frames`` charts of one orbit (see orbit_specs); write them to ``output`` (.gif,
    .webp or .mp4) when given, checked before the first frame is rendered."""
    spec = as_spec(spec, "spec")
    specs = orbit_specs(spec, frames, orbit)
    if output is not None:
        check_animation_output(output, fps)
    _check_fps(fps)
    images = [_chart_frame(s) for s in _frames(specs, f"orbit {orbit}", progress)]
    animation = Animation(_stack(images), float(fps), specs)
    if output is not None:
        write_animation(output, animation.frames, animation.fps)
    return animation


def animate_compare(spec: ChartSpec | str | Path | None, bug_name: str, frames: int = 36, orbit: str = "light", *,
                    output: str | Path | None = None, fps: float = DEFAULT_FPS, progress: bool | None = None,
                    axes: bool | None = None) -> Animation:
    """The correct chart and the same chart with ``bug_name`` on, side by side, both orbiting
    in step; titled with the bug's name and summary, captioned with its explanation."""
    spec = as_spec(spec, "spec")
    bug, correct, buggy = bug_pair(spec, bug_name)
    pairs = list(zip(orbit_specs(correct, frames, orbit), orbit_specs(buggy, frames, orbit)))
    if output is not None:
        check_animation_output(output, fps)
    _check_fps(fps)
    axes = correct.labels if axes is None else axes
    text_size = sheet_text_size(correct.height)
    images, specs = [], []
    for c, b in _frames(pairs, f"{bug.name} orbit {orbit}", progress):
        panels = [chart_panel("correct", render_chart(c), axes, text_size),
                  chart_panel(f"buggy: {bug.name}", render_chart(b), axes, text_size)]
        sheet = assemble([panels], title=f"{bug.name}: {bug.summary}", caption=bug.caption, text_size=text_size)
        images.append(np.array(sheet))
        specs += [c, b]
    animation = Animation(_stack(images), float(fps), specs)
    if output is not None:
        write_animation(output, animation.frames, animation.fps)
    return animation


# ---------------------------------------------------------------------------------------------
# Writing.

def _opaque(frames: np.ndarray) -> np.ndarray:
    """RGB frames for formats without alpha: transparent pixels over the chart background."""
    if frames[..., 3].min() == 255:
        return np.ascontiguousarray(frames[..., :3])
    return np.stack([flatten(f)[..., :3] for f in frames])


def write_animation(path: str | Path, frames: np.ndarray, fps: float = DEFAULT_FPS) -> None:
    """(N, H, W, 4) uint8 frames to .gif / .webp (loop forever) or .mp4, atomically."""
    import imageio.v3 as iio
    frames = np.asarray(frames, np.uint8)
    if frames.ndim != 4 or frames.shape[-1] != 4 or len(frames) == 0:
        raise ValueError(f"expected (N, H, W, 4) uint8 frames, got {frames.shape}")
    p = Path(path)
    suffix = p.suffix.lower()
    duration_ms = 1000.0 / fps
    with atomic_path(p, suffix) as tmp:
        if suffix == ".gif":
            # GIF delays are whole centiseconds, and viewers slow delays under 20 ms down to 100 ms.
            delay_ms = max(20, 10 * round(duration_ms / 10))
            iio.imwrite(tmp, _opaque(frames), plugin="pillow", extension=".gif", duration=delay_ms, loop=0)
        elif suffix == ".webp":
            rgba = frames if frames[..., 3].min() < 255 else np.ascontiguousarray(frames[..., :3])
            iio.imwrite(tmp, rgba, plugin="pillow", extension=".webp", duration=round(duration_ms), loop=0,
                        lossless=True)
        elif suffix == ".mp4":
            rgb = _opaque(frames)
            # H.264 in yuv420p needs even sizes: pad by a row / column of the edge, never scale.
            h, w = rgb.shape[1:3]
            rgb = np.pad(rgb, ((0, 0), (0, h % 2), (0, w % 2), (0, 0)), mode="edge")
            iio.imwrite(tmp, rgb, plugin="FFMPEG", extension=".mp4", fps=fps, codec="libx264",
                        macro_block_size=1, pixelformat="yuv420p", output_params=["-movflags", "+faststart"])
        else:
            raise SpecError(f"output {p} must end in {' or '.join(ANIMATION_SUFFIXES)}")


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
    check_animation_output(args.output, args.fps)
    start = time.perf_counter()
    animation = animate(spec, args.frames, args.orbit, output=args.output, fps=args.fps)
    if args.verbose:
        n, h, w = animation.frames.shape[:3]
        print(f"{args.output}: {n} frames {w}x{h} at {args.fps:g} fps, orbit {args.orbit}, "
              f"{time.perf_counter() - start:.2f} s")
    return 0
