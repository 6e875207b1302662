"""White-furnace energy report: every cell of a chart in a uniform environment of radiance 1,
each pixel against the float64 split-sum expectation at its own NdotV (docs/model.md, the white furnace).

Two different things show up and are kept apart:
- what the *model* does: the expectation itself above 1 (the glTF dielectric coupling gains
  energy at grazing angles) or below 1 (single-scatter GGX loses it at high roughness when
  multiple scattering is off) -- columns ``exp_*``;
- what the *renderer* adds: rendered minus expected -- column ``max_err``.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..oracle.furnace import FurnaceTable
from ..spec.chart_spec import ChartSpec, make_spec

GRAZING_N_DOT_V = 0.2


# What a white furnace sets whatever the spec says: a uniform environment of radiance 1 seen
# through IBL only, no lights, ground or AO, one sample per pixel at its centre, no edge blending.
FURNACE = dict(env="uniform", env_intensity=1.0, lights=(), ground=False, ao=False, shadows=False,
               ibl=True, transparent=False, spp=1, antialias=False)


def furnace_is_white(spec: ChartSpec, white: bool = True) -> bool:
    """Whether ``spec``'s furnace turns its base colours white when ``white`` is asked: not a
    glTF asset's, whose materials keep their own colours."""
    return white and not spec.gltf


def furnace_spec(spec: ChartSpec, white: bool = True) -> ChartSpec:
    """The spec in a white furnace (FURNACE), so each pixel is the BRDF at the AOV's NdotV,
    grazing angles included; its base colours white where furnace_is_white says."""
    overrides = dict(FURNACE)
    if furnace_is_white(spec, white):
        overrides.update(base_color=(1.0, 1.0, 1.0), row_materials=())
    return make_spec(spec, **overrides)


def replaced_settings(spec: ChartSpec) -> list[str]:
    """The settings of ``spec`` a white furnace replaces that are not at their defaults (the
    command says so rather than drop them silently)."""
    default = ChartSpec()
    return [name for name in FURNACE if getattr(spec, name) != getattr(default, name)]


@dataclass
class CellEnergy:
    row: int
    col: int
    metallic: float
    roughness: float
    pixels: int
    min_n_dot_v: float
    rendered_min: float
    rendered_mean: float
    rendered_max: float
    exp_min: float
    exp_mean: float
    exp_max: float
    max_err: float          # largest |rendered - expected| at NdotV >= GRAZING_N_DOT_V, same pixel
    grazing_max_err: float  # the same over pixels with NdotV < GRAZING_N_DOT_V (nan if none)
    grazing_rendered_max: float
    grazing_exp_max: float


def cell_energy(result, spec: ChartSpec, table=None) -> list[CellEnergy]:
    """Per cell statistics of the mean over RGB of rendered and expected radiance."""
    table = table or FurnaceTable()
    aov = result.aov
    cells = []
    bases = spec.material_array("base_color")
    for row in range(spec.rows):
        for col in range(spec.cols):
            m = (aov["row"] == row) & (aov["col"] == col)
            if not m.any():
                continue
            n_dot_v = aov["ndotv"][m].astype(np.float64)
            rough = aov["roughness"][m].astype(np.float64)
            metal = aov["metallic"][m].astype(np.float64)
            want = spec.env_intensity * table.expected(n_dot_v, rough, bases[row, col], metal,
                                                       spec.brdf, spec.multiscatter)
            got = result.hdr[m].astype(np.float64)
            g, w = got.mean(-1), want.mean(-1)
            graze = n_dot_v < GRAZING_N_DOT_V
            err = np.abs(got - want).max(-1)
            cells.append(CellEnergy(
                row, col, float(metal[0]), float(rough[0]), int(m.sum()), float(n_dot_v.min()),
                float(g.min()), float(g.mean()), float(g.max()), float(w.min()), float(w.mean()), float(w.max()),
                float(err[~graze].max()) if (~graze).any() else float("nan"),
                float(err[graze].max()) if graze.any() else float("nan"),
                float(g[graze].max()) if graze.any() else float("nan"),
                float(w[graze].max()) if graze.any() else float("nan")))
    return cells


def model_summary(cells: list[CellEnergy], white: bool) -> list[str]:
    """Plain statements of where the model gains or loses energy and what the renderer adds."""
    if not cells:
        return ["no sphere pixels were rendered"]
    lines = []
    gain = max(cells, key=lambda c: c.exp_max)
    loss = min(cells, key=lambda c: c.exp_min)
    worst = max(cells, key=lambda c: np.nan_to_num(c.max_err))
    worst_grazing = max(cells, key=lambda c: np.nan_to_num(c.grazing_max_err))
    if white and gain.exp_max > 1 + 1e-3:
        lines.append(f"model gains energy: up to {gain.exp_max:.3f} (metallic {gain.metallic:g}, roughness "
                     f"{gain.roughness:g}, grazing NdotV {gain.min_n_dot_v:.3f}) -- the glTF coupling weights the "
                     f"Lambert body by 1 - F(VdotH), far from grazing for most light directions, while the "
                     f"coat reflects F at the grazing view: together more than 1")
    if white and loss.exp_min < 1 - 1e-3:
        why = ("single-scatter GGX: multiple scattering is off" if loss.metallic == 1 else
               "the Lambert weight 1 - F does not take back what the rough specular lobe loses")
        lines.append(f"model loses energy: down to {loss.exp_min:.3f} (metallic {loss.metallic:g}, roughness "
                     f"{loss.roughness:g}) -- {why}")
    if white and not lines:
        lines.append("model conserves energy within 1e-3 in every cell")
    lines.append(f"renderer vs model: largest per-pixel |rendered - expected| {worst.max_err:.2e} at NdotV >= "
                 f"{GRAZING_N_DOT_V:g} (metallic {worst.metallic:g}, roughness {worst.roughness:g}), "
                 f"{worst_grazing.grazing_max_err:.2e} below it (metallic {worst_grazing.metallic:g}, roughness "
                 f"{worst_grazing.roughness:g}; the DFG LUT's NdotV resolution)")
    return lines


def format_table(cells: list[CellEnergy]) -> str:
    head = (f"{'row':>3s} {'col':>3s} {'metal':>5s} {'rough':>6s} {'px':>6s} {'minNdV':>6s} "
            f"{'rendered min/mean/max':>23s} {'expected min/mean/max':>23s} {'max_err':>8s} {'graz.err':>8s} "
            f"{'grazing r/e max':>15s}")
    lines = [head]
    for c in cells:
        graze = "-" if np.isnan(c.grazing_exp_max) else f"{c.grazing_rendered_max:.3f}/{c.grazing_exp_max:.3f}"
        lines.append(f"{c.row:3d} {c.col:3d} {c.metallic:5.2f} {c.roughness:6.3f} {c.pixels:6d} {c.min_n_dot_v:6.3f} "
                     f"{c.rendered_min:7.3f}/{c.rendered_mean:7.3f}/{c.rendered_max:7.3f} "
                     f"{c.exp_min:7.3f}/{c.exp_mean:7.3f}/{c.exp_max:7.3f} {c.max_err:8.1e} {c.grazing_max_err:8.1e} "
                     f"{graze:>15s}")
    return "\n".join(lines)


def to_json(spec: ChartSpec, cells: list[CellEnergy], white: bool) -> dict:
    return {"spec": spec.to_dict(), "grazing_n_dot_v": GRAZING_N_DOT_V,
            "cells": [{k: (None if isinstance(v, float) and np.isnan(v) else v) for k, v in asdict(c).items()}
                      for c in cells],
            "summary": model_summary(cells, white)}
