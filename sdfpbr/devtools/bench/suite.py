"""What the benchmark measures: the scene suite, the presets, the ablations, and the
configuration of a run (checked before anything is measured)."""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from ...errors import SpecError, did_you_mean
from ...spec.chart_spec import QUALITY_PRESETS, ChartSpec, Light, make_spec
from ...spec.presets import QUALITY_LEVELS

# The scene suite. Each scene is a set of spec overrides on the default chart.
SCENES: dict[str, dict] = {
    "default": {},                                    # 5x5, studio env, key + fill light, ground
    "cells": {"stage": "cells"},                      # each sphere on its own floor (identical cells)
    "shared": {"stage": "shared"},                    # one floor under the grid, neighbours reflected
    "grid3x3": {"rows": 3, "cols": 3},
    "grid10x10": {"rows": 10, "cols": 10},
    "bare": {"ground": False, "shadows": False, "ao": False},
    # White furnace: white spheres in a uniform environment, nothing else. An energy-conserving
    # BRDF leaves every sphere at the background's radiance, so any error left is the
    # IBL/BRDF integration (split sum, DFG LUT, multiple-scattering compensation).
    "furnace": {"env": "uniform", "lights": "none", "ground": False, "shadows": False, "ao": False,
                "base_color": (1.0, 1.0, 1.0)},
    # The default chart before its orange base and soft boxes: a grey base under a 2.5-degree
    # sun and a point light, the scene the stage's accuracy was first measured on (kept so those
    # figures stay comparable: FLIP reads a coloured chart's errors larger).
    "grey": {"stage": "cells", "base_color": (0.75, 0.75, 0.75),
             "lights": (Light("directional", direction=(-0.55, 0.65, 0.52), color=(1.0, 0.95, 0.88), intensity=3.0,
                              angular_radius_deg=2.5),
                        Light("point", position=(9.0, 1.5, 7.0), color=(0.85, 0.92, 1.0), intensity=25.0, range=60.0))},
    # Every KHR lobe at once on the cells stage: clearcoat down the rows over a sheened,
    # ior-2 dielectric (roughness across), so the chart composes clearcoat, sheen and specular.
    "lobes": {"stage": "cells", "y_axis": "clearcoat", "metallic": 0.0, "base_color": (0.2, 0.3, 0.7),
              "sheen_color": (0.6, 0.3, 0.4), "sheen_roughness": 0.5, "ior": 2.0, "clearcoat_roughness": 0.1},
}
SCENE_NOTES = {
    "default": "the default 5x5 chart",
    "cells": "5x5, cells stage: a sphere on its own floor per cell",
    "shared": "5x5, shared stage: one floor, neighbours in reflections",
    "grid3x3": "3x3 spheres",
    "grid10x10": "10x10 spheres",
    "bare": "no ground, shadows or AO",
    "furnace": "white spheres, uniform env, no lights/ground (white furnace)",
    "grey": "5x5 cells stage, grey base, sun and point light (the earlier default)",
    "lobes": "5x5 cells stage, roughness x clearcoat over sheen and ior 2 (the KHR lobes)",
}
BASE_PRESETS = QUALITY_LEVELS   # the presets for use; seed002 is the baseline beside them

# Ablation: one feature off at a time on the default scene (preset "default"). The spec has one
# IBL switch (diffuse and specular IBL go together).
ABLATIONS: dict[str, dict] = {
    "shadows": {"shadows": False},
    "ao": {"ao": False},
    "ibl": {"ibl": False},
    "lights": {"lights": "none"},
    "ground": {"ground": False},
    "spp4": {"spp": 4},                # the cost of 4 samples per pixel over 1
    "march": {"intersect": "march"},   # sphere tracing instead of the analytic ray-sphere hit
}
# Identifiers (code, not comments) that belong to a feature: none may remain without it.
FEATURE_IDENTIFIERS = {
    "shadows": re.compile(r"shadow"),
    "ao": re.compile(r"occlusion|(^|_)ao(_|$)"),
    "ibl": re.compile(r"prefilter|irradiance|(^|_)sh(_|$)|(^|_)ibl(_|$)"),
    "lights": re.compile(r"(dir|point)_light"),
    "ground": re.compile(r"(^|_)ground"),
}
# "Pays nothing": a feature the scene asks for but cannot use must cost nothing. Each pair is
# (asks for it, leaves it out); both should compose to the same source and time the same.
ABSENT_PAIRS: dict[str, tuple[dict, dict]] = {
    "shadows-without-ground": ({"ground": False, "shadows": True}, {"ground": False, "shadows": False}),
    "shadows-without-lights": ({"lights": "none", "shadows": True}, {"lights": "none", "shadows": False}),
    "ao-without-ibl": ({"ibl": False, "ao": True}, {"ibl": False, "ao": False}),
}

REQUIRED_KEYS = ("scene", "preset", "render_ms", "compile_ms", "cold_s", "flip_mean", "rel_rmse")


def available_presets() -> tuple[str, ...]:
    return BASE_PRESETS + tuple(p for p in ("seed002",) if p in QUALITY_PRESETS)


@dataclass
class BenchConfig:
    scenes: tuple[str, ...] = tuple(SCENES)
    presets: tuple[str, ...] = field(default_factory=available_presets)
    width: int = 1024
    height: int = 1024
    repeats: int = 5
    warmup: int = 1
    ref_samples: int = 256
    seed: int = 0
    reference: bool = True
    cold: bool = True
    ablation: bool = False
    baseline: str | None = None
    backend: str = "auto"
    heatmaps: str | None = None      # directory for FLIP heat maps, one per scene x preset
    log: object = None               # a callable taking one progress line, or None

    @classmethod
    def quick(cls, **overrides) -> "BenchConfig":
        """CI-sized: 256^2, two scenes, two presets, 3 repeats, 512-sample references: enough for
        the spheres' mean luminance to judge every preset (accuracy.cell_bias_columns), not
        FLIP, which needs tens of thousands."""
        base = dict(scenes=("default", "bare"), presets=("draft", "default"), width=256, height=256,
                    repeats=3, warmup=1, ref_samples=512)
        base.update(overrides)
        return cls(**base)


def pick_choices(values, allowed, what: str) -> tuple[str, ...]:
    out = []
    for v in values:
        if v not in allowed:
            raise SpecError(f"unknown {what} {v!r}{did_you_mean(v, allowed)}; allowed: {', '.join(allowed)}")
        if v not in out:
            out.append(v)
    if not out:
        raise SpecError(f"no {what} selected; allowed: {', '.join(allowed)}")
    return tuple(out)


def check_config(cfg: BenchConfig) -> BenchConfig:
    cfg.scenes = pick_choices(cfg.scenes, tuple(SCENES), "scene")
    cfg.presets = pick_choices(cfg.presets, available_presets(), "preset")
    for name, lo in (("repeats", 1), ("warmup", 0), ("ref_samples", 1)):
        v = getattr(cfg, name)
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise SpecError(f"--{name.replace('_', '-')} must be a whole number >= {lo}, got {v!r}")
    make_spec(width=cfg.width, height=cfg.height, backend=cfg.backend)   # validates the size
    if cfg.reference:
        from .accuracy import reference_samples_cap
        cap = reference_samples_cap()
        if cap is not None and cfg.ref_samples > cap:
            raise SpecError(f"--ref-samples must be at most {cap} (the reference's most samples a pixel), "
                            f"got {cfg.ref_samples}")
    if cfg.baseline is not None:
        from ..baseline import load_shadertoy
        load_shadertoy(cfg.baseline)      # a bad path or a document without GLSL fails now
    if cfg.heatmaps is not None:
        p = Path(cfg.heatmaps)
        if p.exists() and not p.is_dir():
            raise SpecError(f"--heatmaps {p} exists and is not a directory")
        if not (p if p.exists() else p.parent if str(p.parent) else Path(".")).is_dir():
            raise SpecError(f"--heatmaps {p}: directory {p.parent} does not exist")
    return cfg


def scene_overrides(scene: str) -> dict:
    """A scene's spec overrides as the bench renders it: without the cells' page-colour borders,
    which are the same pixels in the chart and the reference and would dilute the error it
    measures (4.6 % of the default frame's pixels)."""
    return {"cell_borders": False, **SCENES[scene]}


def scene_spec(scene: str, cfg: BenchConfig, preset: str = "default", **extra) -> ChartSpec:
    return make_spec(width=cfg.width, height=cfg.height, backend=cfg.backend, quality=preset,
                     **{**scene_overrides(scene), **extra})
