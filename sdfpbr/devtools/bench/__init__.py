"""The speed/error benchmark behind ``sdfpbr bench``.

For every scene of a fixed suite and every quality preset it measures

* ``render_ms``: the chart program's draw at the full resolution, median of ``repeats`` draws
  after ``warmup`` draws. On hardware drivers a GL timer query times each draw; Mesa's
  software rasterizers (llvmpipe) answer timer queries with the time to *queue* the draw, not
  to run it, so there each draw is bracketed by ``ctx.finish()`` and timed on the wall clock.
  The timed draw is checked against the renderer's own output (``draw_check``), so what is
  timed is what the chart shows.
* ``compile_ms``: link of a fresh program (a nonce comment defeats every shader cache) plus
  its first draw on a small target of the chart's formats, where llvmpipe JIT-compiles.
* ``source_bytes``: the composed chart source.
* ``cold_s``: wall time of a fresh ``python -m sdfpbr chart`` process with Mesa's shader cache
  disabled and an empty sdfpbr disk cache (IBL bakes and LUTs recomputed); ``cold_warm_cache_s``:
  the same right after, with the sdfpbr disk cache filled (bakes, LUTs and the cells stage's
  prepasses: the user's second run); ``start_s``:
  the median of three more with Mesa's shader cache warm too (every later run).
* error against the reference renderer (``sdfpbr.features.reference``): mean LDR FLIP of the display
  images over the whole frame (``flip_mean``) and over sphere pixels (``flip_sphere_mean``),
  HDR FLIP, and relative RMSE of linear radiance over sphere pixels (``rel_rmse``). References
  are rendered once per scene (the scene's truth does not depend on the preset) and cached on
  disk, keyed by the scene, sample count, seed, sdfpbr version and the reference code.

Modules: ``suite`` (scenes, presets, ablations, the configuration), ``timing`` (draws and
compiles on a GL context), ``cold`` (fresh processes), ``accuracy`` (cached references and the
error columns), ``ablation`` (one feature off at a time), ``run`` (the benchmark),
``report`` (table, JSON, plot) and ``end_to_end`` (``--end-to-end``: what a chart costs around
its draw, each figure beside its target).
"""
