"""The reference's labels: the chart's layout around its render, with a footer that says how it
was traced. No pixel of a reference depends on this module, so the bench's reference key
leaves it out (tools/bench/accuracy.py): a label edit keeps hours of cached references."""
from __future__ import annotations

import math

import numpy as np

from ...image.chart_labels import default_title, footer_scene_parts, label as chart_label
from ...image.layout import FOOTER_SEPARATOR
from ...spec.chart_spec import ChartSpec
from .integrator import ReferenceResult


def footer_text(result: ReferenceResult) -> str:
    """The chart's scene settings (its frame's: the reference shades with the spec's BRDF),
    then how the reference was traced."""
    err = f", rel. stderr {result.error:.2%}" if math.isfinite(result.error) else ""
    parts = footer_scene_parts(result.frame) + [
        f"path-traced reference, {result.samples} spp, {result.max_bounces} bounces{err}"]
    return FOOTER_SEPARATOR.join(parts)


def label(spec: ChartSpec, result: ReferenceResult) -> np.ndarray:
    """The chart's labeled layout around the reference render."""
    return chart_label(spec, result, title=f"{default_title(spec)} (reference)",
                       footer=footer_text(result))
