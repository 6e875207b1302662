"""Ground truth for the chart: a progressive Monte Carlo path tracer of exactly the chart's scene.

Same sphere grid, ground, camera, environment function (env.glsl evaluated per ray, not the
baked cubemap), lights and BRDF module (brdf.glsl, compensation on or off as the spec says)
as the chart, on the same GL context. What the chart approximates, the reference does exactly:
analytic ray-sphere/plane visibility for every ray, true shadow rays for every light and
for the environment (no AO), the sun as a disc of finite radiance, interreflections.

Stages: on the shared stage the spheres stand in one grid over one floor, traversed exactly
by a grid DDA; on the cells stage (``stage = "cells"``) each pixel first moves into its cell's
frame (``cell_pixel`` in scene.glsl, as the chart does) and every ray of its paths sees that
cell's scene only, one sphere at the origin on its own floor y = -R, so shadows, occlusion and
interreflection between the sphere and its floor are exact and every cell is the same scene.

Pixel footprint: both the chart (spp > 1) and the reference integrate the unit pixel square
[p, p + 1)^2 (in the cell's frame on the cells stage) with a box filter: the chart on a rank-1
lattice centred in it, the reference at fract(rotation + s R2); the AOVs of both are the
pixel centre's (tests/test_reference_cells.py checks the coverage of silhouette pixels).

Sampling: GGX visible normals (Heitz 2018) mixed with cosine-weighted diffuse, one light
sample per light and one environment sample (a tabulated equirect CDF) per surface point,
combined by multiple importance sampling with the power heuristic. Pixel samples follow the
R2 sequence under a per-pixel random rotation; all random numbers are hashes of (seed,
pixel, sample, draw), so a seed gives bit-identical output. Each pixel adds its samples one by
one in sample order, so a run resumed from another's accumulators (``resume``) with more
samples gives the bits of the straight run; the bench goes on from its cached references so.

The energy compensation's single-scatter albedo E(NdotV, r) comes from a float64 quadrature
table (sdfpbr.oracle.shading_model), not the chart's sampled LUT, so the reference integrates the model
itself rather than the chart's approximation of it. For the schlick-ggx model the reference
uses the punctual-light visibility (k = (r+1)^2/8) for every direction, since a path tracer
needs one BRDF; the chart's IBL uses k = alpha/2 and differs from it by construction.

Error: per pixel, the standard error of the mean of the samples' luminance, from running
sums kept about a per-pixel shift. The stopping metric is the MEAN RELATIVE STANDARD ERROR
over sphere pixels (pixels whose centre ray hits a sphere): mean of stderr / max(mean, floor)
with floor = 1% of the mean luminance of those pixels, so near-black pixels do not dominate.
Pixel samples are stratified, so the per-pixel estimate is conservative (it assumes
independent samples).
"""
from __future__ import annotations

from .integrator import (DEFAULT_MAX_BOUNCES, Accumulators, ReferenceResult, batch_size, cell_reach,
                         relative_error, render_reference, run_key, scene_fields, validate_arguments)
from .labels import footer_text, label
from .tables import compensation_choice, compensation_table, environment_cdfs

__all__ = ["DEFAULT_MAX_BOUNCES", "Accumulators", "ReferenceResult", "batch_size", "cell_reach",
           "compensation_choice", "compensation_table", "environment_cdfs", "footer_text", "label", "relative_error",
           "render_reference", "run_key", "scene_fields", "validate_arguments"]
