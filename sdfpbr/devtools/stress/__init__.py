"""Seeded stress sweeps over the edges users reach for: roughness exactly 0, grazing
silhouettes, blinding or tiny lights, far cameras, giant images, half-float targets, both
backends. Every configuration is rendered and checked against properties derived without the
renderer (the checks are plain functions of arrays, tested on their own):

- finite:    no NaN, Inf or negative radiance; coverage in [0, 1];
- display:   the display image equals the float64 model's exposure -> tone map -> sRGB of
             the HDR within 1 LSB wherever the HDR is finite (a NaN born in the display pass
             shows up here);
- furnace:   in a uniform environment every sphere and ground pixel matches the float64
             split-sum expectation (docs/model.md, the white furnace), the background the environment;
             the spheres only where there is no floor (with one, they see it below them);
- firefly:   no pixel is brighter than FIREFLY_RATIO x its brightest neighbour where shading
             must vary smoothly (see ``isolated_outliers`` for why that region is safe);
- monotonic: at a highlight centre shared by every column the radiance falls as roughness
             rises (equal where the roughness clamp makes the lobes equal) and matches the
             float64 BRDF;
- tiles:     a render cut into small tiles equals the single-tile render bit for bit.

Configurations that share a composed program (same compile options) are grouped into
families, so a sweep compiles a few dozen programs, not thousands; one GL session per backend
keeps programs, LUTs and IBL bakes across the whole sweep.

The package is split by concern: ``cases`` draws the configurations, ``checks`` holds the
property checks (plain functions of arrays), ``runner`` renders and checks them, ``report``
summarises the outcomes and writes failing configurations as TOML specs. The float64 furnace
expectation is ``sdfpbr.oracle.furnace``.
"""
