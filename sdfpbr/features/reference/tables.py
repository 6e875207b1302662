"""The reference's tables, uploaded once per session: the energy compensation's single-scatter
albedo E(NdotV, r) by float64 quadrature (so the reference integrates the model itself, not
the chart's sampled LUT) and the environment's importance-sampling CDFs."""
from __future__ import annotations

import math
from pathlib import Path

import moderngl
import numpy as np

from ...cache import content_key
from ...gpu.frame import table_texture
from ...gpu.programs import set_uniforms
from ...oracle import lobes, shading_model

COMPENSATION_TABLE_SIZE = 128  # E(NdotV, r) grid, float64 quadrature (bilinear error < 4e-4)
COMPENSATION_QUADRATURE = 16   # Gauss-Legendre order: within 7e-7 of order 32 on this grid
ENV_MAP_SIZE = (512, 256)      # equirect sampling table (W, H)
ENV_SUPERSAMPLE = 2            # env evaluations per texel edge
LOCAL = 8                      # compute work-group edge


_tables: dict = {}   # this process's tables by key: a bench keys each reference by its table


def compensation_choice(spec, plan) -> dict:
    """The compensation table a reference of ``spec`` (its plan ``plan``) reads:
    compensation_table's model and sheen."""
    return {"model": spec.brdf, "sheen": bool(plan.options.get("SHEEN"))}


def compensation_table(model: str, cache=None, sheen: bool = False) -> np.ndarray:
    """(size, size, 4) float32: [j, i] = (A, B, C, E_s or 1) at NdotV = i/(size-1), r = j/(size-1),
    the layout dfg.glsl reads, by float64 quadrature (sdfpbr.oracle.shading_model, .lobes for the
    sheen's albedo E_s when ``sheen``), disk-cached."""
    size, order = COMPENSATION_TABLE_SIZE, COMPENSATION_QUADRATURE
    key = content_key("reference-dfg", model, size, order, sheen, Path(shading_model.__file__).read_bytes(),
                      Path(lobes.__file__).read_bytes() if sheen else b"")
    if key in _tables:
        return _tables[key]
    cached = cache.get("reference_dfg", key) if cache is not None else None
    if cached is not None:
        _tables[key] = cached["table"]
        return cached["table"]
    grid = np.arange(size, dtype=np.float64) / (size - 1)
    a, b, c = shading_model.dfg_integrate(np.maximum(grid[None, :], shading_model.MIN_N_DOT_V), grid[:, None],
                                          model=model, n=order)
    e_sheen = (lobes.sheen_albedo(np.maximum(grid[None, :], shading_model.MIN_N_DOT_V), grid[:, None])
               if sheen else np.ones_like(a))
    table = np.stack([a, b, c, e_sheen], axis=-1).astype(np.float32)
    if cache is not None:
        cache.put("reference_dfg", key, {"table": table})
    _tables[key] = table
    return table


def compensation_texture(session, model: str, sheen: bool = False):
    name = f"reference-dfg:{model}:{sheen}"
    if name not in session.tables:
        table = compensation_table(model, session.cache, sheen)
        size = table.shape[0]
        tex = session.ctx.texture((size, size), 4, np.ascontiguousarray(table).tobytes(), dtype="f4")
        tex.repeat_x = tex.repeat_y = False
        tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        session.tables[name] = tex
    return session.tables[name]


def environment_cdfs(radiance: np.ndarray) -> dict | None:
    """Sampling tables from an (H, W, 3) equirect average radiance map (row 0 at the zenith):
    texel probabilities P proportional to (luminance + floor) sin(theta), the marginal CDF
    over rows and the conditional CDF within each row. None when the map has no radiance."""
    h, w = radiance.shape[:2]
    lum = radiance[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])
    sin_theta = np.sin((np.arange(h) + 0.5) / h * np.pi)[:, None]
    mean = float(np.sum(lum * sin_theta) / (np.sum(sin_theta) * w))
    if not (math.isfinite(mean) and mean > 0.0):
        return None
    # A floor keeps every direction samplable (MIS stays unbiased where the table missed light).
    weight = (np.maximum(lum, 0.0) + 1e-3 * mean) * sin_theta
    p = weight / weight.sum()
    row = p.sum(axis=1)
    marginal = np.concatenate([[0.0], np.cumsum(row)])
    marginal /= marginal[-1]
    conditional = np.concatenate([np.zeros((h, 1)), np.cumsum(p, axis=1)], axis=1) / row[:, None]
    conditional[:, -1] = 1.0
    return {"marginal": marginal.astype(np.float32)[None, :], "conditional": conditional.astype(np.float32),
            "probability": p.astype(np.float32)}


def environment_sampling(session, program_source, env) -> dict | None:
    """Per-session textures for environment sampling, keyed by the environment's content:
    sampler name -> texture, plus "size"; None for an environment without radiance."""
    name = "reference-env:" + env.content
    if name in session.tables:
        return session.tables[name]
    ctx = session.ctx
    tables = None
    if env.option != "black":
        program = session.programs.compute(program_source)
        w, h = ENV_MAP_SIZE
        target = ctx.texture((w, h), 4, dtype="f4")
        target.bind_to_image(0, read=False, write=True)
        uniforms = {**env.uniforms, "u_size": (w, h), "u_supersample": ENV_SUPERSAMPLE}
        if env.texture is not None:
            env.texture.use(4)
            uniforms["u_env_map"] = 4
        set_uniforms(program, uniforms)
        program.run((w + LOCAL - 1) // LOCAL, (h + LOCAL - 1) // LOCAL)
        ctx.memory_barrier()
        radiance = np.frombuffer(target.read(), np.float32).reshape(h, w, 4)
        target.release()
        tables = environment_cdfs(radiance)
    textures = None
    if tables is not None:
        textures = {}
        for key, uniform in (("marginal", "u_env_marginal_cdf"), ("conditional", "u_env_conditional_cdf"),
                             ("probability", "u_env_texel_probability")):
            textures[uniform] = table_texture(ctx, tables[key])
        textures["size"] = (tables["probability"].shape[1], tables["probability"].shape[0])
    session.tables[name] = textures
    return textures
