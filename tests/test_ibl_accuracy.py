"""Image-based lighting against the exact float64 integral (issue 9, must have 3).

The environment is sdfpbr.oracle.ibl_integral.LobeSky (a sky gradient plus a sharp bright
lobe), handed to the chart as the .npy equirect map it writes, so the spec needs no test preset.
The chart renders IBL alone (no lights, floor, AO or shadows) on a 3 x 5 grid (metallic 0, 0.5,
1 down the rows, roughness 0 .. 1 across); each sphere pixel's n and v come from the AOVs and
the camera, and the oracle integrates f(v, l) L(l) cos over l at that pixel.

Targets (issue 9): NdotV 0.3 - 0.95, mean relative error per cell (roughness x metallic)
within 5 % for `default` and 1.5 % for `high`. `python tests/test_ibl_accuracy.py` prints the
table (40 pixels per cell and band). Measured when this was written, worst cell: default 5.0 %
(metal, r = 0.75; 5.6 % with the one-read ramps, 22.8 % before any correction), high 1.2 % (30.3 %
before); mean over cells 2.21 / 0.69 %.
"""
import dataclasses

import numpy as np
import pytest

from helpers import FurnaceBudget
from sdfpbr.gpu.ibl import make_environment
from sdfpbr.oracle import ibl_integral as oracle
from sdfpbr.oracle import shading_model
from sdfpbr.shading.camera import frame_grid, sphere_centers
from sdfpbr.shading.plan import chart_frame, prefilter_kernel, render_plan
from sdfpbr.spec.chart_spec import make_spec
from sdfpbr.spec.presets import QUALITY_PRESETS

ENV = oracle.LobeSky()
BANDS = ((0.3, 0.5), (0.5, 0.7), (0.7, 0.95))     # NdotV bands; the target covers 0.3 - 0.95
PER_BAND = 12                                      # pixels per cell and band for the oracle
TARGET = {"default": 0.05, "high": 0.015}          # mean relative error per cell (issue 9)
# The base colour the targets were set and measured on: a grey, so a cell's error is
# the lobe's, not a dark channel's (the orange default reads 5.9 % in the r = 0.5 metal cell).
GREY_BASE = (0.75, 0.75, 0.75)


def ibl_spec(env_path, quality="default", **kw):
    return make_spec(env=str(env_path), lights="none", ground=False, ao=False, shadows=False,
                     rows=3, cols=5, width=320, height=192, quality=quality, tonemap="none",
                     stage="shared", base_color=GREY_BASE, **kw)


def pick_pixels(spec, aov, per_band=PER_BAND, seed=0):
    """Per (cell, band) up to ``per_band`` sphere pixels, with their n (AOV) and v (camera)."""
    row, col, nv = aov["row"], aov["col"], aov["ndotv"]
    rng = np.random.default_rng(seed)
    picked = []
    for i in range(spec.rows):
        for j in range(spec.cols):
            for b, (lo, hi) in enumerate(BANDS):
                ys, xs = np.nonzero((row == i) & (col == j) & (nv >= lo) & (nv <= hi))
                assert ys.size >= per_band, f"cell {i},{j} band {b}: {ys.size} pixels"
                k = rng.choice(ys.size, per_band, replace=False)
                picked += [(i, j, b, y, x) for y, x in zip(ys[k], xs[k])]
    i, j, b, y, x = np.array(picked).T
    n = aov["normal"][y, x].astype(np.float64)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    p = sphere_centers(spec)[i, j] + spec.sphere_radius * n
    v = frame_grid(spec).position - p
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    return {"i": i, "j": j, "b": b, "y": y, "x": x, "n": n, "v": v,
            "r": spec.material_array("roughness")[i, j], "m": spec.material_array("metallic")[i, j]}


def cell_errors(spec, px, hdr, want):
    """(rows, cols) mean over pixels and channels of |got / want - 1|, NdotV 0.3 - 0.95."""
    rel = np.abs(hdr[px["y"], px["x"]].astype(np.float64) / want - 1.0).mean(-1)
    out = np.zeros((spec.rows, spec.cols))
    for i in range(spec.rows):
        for j in range(spec.cols):
            out[i, j] = rel[(px["i"] == i) & (px["j"] == j)].mean()
    return out


@pytest.fixture(scope="module")
def env_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("ibl_env") / "lobe_sky.npy"
    np.save(path, ENV.to_equirect(1024))
    return path


@pytest.fixture(scope="module")
def truth(session, env_path):
    """The pixels (picked on a default render; the geometry does not depend on the preset) and
    the float64 integral at each."""
    spec = ibl_spec(env_path)
    px = pick_pixels(spec, session.render(spec).aov)
    want = oracle.ibl_integral(px["n"], px["v"], np.asarray(spec.base_color), px["m"], px["r"], ENV)
    return px, want


def errors_for(session, env_path, truth, quality):
    spec = ibl_spec(env_path, quality)
    px, want = truth
    return cell_errors(spec, px, session.render(spec).hdr, want)


# ---- the oracle itself --------------------------------------------------------------------

def _points(m, seed=1):
    rng = np.random.default_rng(seed)
    n = shading_model.normalize(rng.normal(size=(m, 3)))
    t = rng.normal(size=(m, 3))
    t = shading_model.normalize(t - np.sum(t * n, -1, keepdims=True) * n)
    mu = rng.uniform(0.3, 0.95, m)
    v = mu[:, None] * n + np.sqrt(1 - mu * mu)[:, None] * t
    return n, v, mu, rng.choice([0.0, 0.25, 0.5, 0.75, 1.0], m), rng.choice([0.0, 0.5, 1.0], m)


def test_oracle_under_uniform_light_is_the_furnace():
    n, v, mu, r, m = _points(40)
    got = oracle.ibl_integral(n, v, 0.75, m, r, oracle.UNIFORM)
    np.testing.assert_allclose(got, shading_model.furnace_expected(mu, 0.75, m, r), rtol=1e-8)


def test_oracle_quadrature_is_converged():
    """Doubling every quadrature order moves no value by more than 2e-4 relative (measured
    6e-5), well inside the 1e-3 the accuracy tests need."""
    n, v, _, r, m = _points(30, seed=2)
    a = oracle.ibl_integral(n, v, 0.75, m, r, ENV)
    b = oracle.ibl_integral(n, v, 0.75, m, r, ENV, orders={k: 2 * o for k, o in oracle.ORDERS.items()})
    assert np.abs(a / b - 1).max() < 2e-4


def test_oracle_matches_brute_force_sum_of_mirror_brdf():
    """An independent check of the parametrisation: shading_model.brdf summed over a fine midpoint
    grid of the whole sphere of directions, within the sum's own error (its step from a grid
    half as fine: the horizon's kink, off the grid's pole, keeps the rule below second order;
    for any order from one the step bounds the error) and the oracle's (its step to twice its
    orders)."""
    n, v, mu, _, _ = _points(1, seed=3)
    r, metal = 0.75, 0.5
    want = oracle.ibl_integral(n, v, 0.75, metal, r, ENV)[0]
    finer = oracle.ibl_integral(n, v, 0.75, metal, r, ENV, orders={k: 2 * o for k, o in oracle.ORDERS.items()})[0]
    A, B, _ = shading_model.dfg_integrate(mu, r)

    def brute(N):
        th = (np.arange(N) + 0.5) / N * np.pi
        ph = (np.arange(2 * N) + 0.5) / (2 * N) * 2 * np.pi
        T, P = np.meshgrid(th, ph, indexing="ij")
        l = np.stack([np.sin(T) * np.cos(P), np.cos(T), np.sin(T) * np.sin(P)], -1).reshape(-1, 3)
        dw = (np.sin(T) * (np.pi / N) ** 2).reshape(-1)
        f = shading_model.brdf(n[0], v[0], l, 0.75, metal, r, multiscatter=True, e_spec=A + B)
        return np.sum(f * ENV.radiance(l) * (np.maximum(l @ n[0], 0) * dw)[:, None], axis=0)
    got, coarse = brute(900), brute(450)
    assert (np.abs(got - want) <= np.abs(coarse - got) + np.abs(want - finer) + 1e-12).all(), (got, want)


# ---- the prefiltered levels ---------------------------------------------------------------

# Mean |relative error| per level against the float64 prefilter of the same environment.
# Before the fix (+1 lod bias, one sample count for every level) the default preset measured
# +3.1 % (r = 0.2) rising to +21 % (r = 1) of over-blur; now <= 0.64 % (r = 0.2), <= 0.2 % above.
LEVEL_BOUND = {"draft": 0.02, "default": 0.01, "high": 0.005}


@pytest.mark.parametrize("quality", ["draft", "default", "high"])
def test_prefiltered_levels_match_float64_prefilter(session, env_path, quality):
    spec = ibl_spec(env_path, quality)
    rng = np.random.default_rng(4)
    with session:
        plan = render_plan(spec).ibl
        lighting = session.ibl.lighting(make_environment(session.ctx, chart_frame(spec)), plan)
        for k in range(lighting.lods + 1):
            level = session.ibl.read_level(plan, lighting, k)[..., :3].astype(np.float64).reshape(-1, 3)
            d = oracle.cube_directions(plan.size >> k).reshape(-1, 3)
            idx = rng.choice(len(d), min(len(d), 200), replace=False)
            want = oracle.prefiltered(d[idx], k / lighting.lods, ENV, 64, 64,
                                      kernel=prefilter_kernel(QUALITY_PRESETS[quality]))
            rel = level[idx] / want - 1
            assert np.abs(rel).mean() < LEVEL_BOUND[quality], (k, np.abs(rel).mean())
            assert abs(rel.mean()) < LEVEL_BOUND[quality], (k, rel.mean())


# ---- the chart against the integral -------------------------------------------------------


def test_default_within_target_on_every_cell(session, env_path, truth):
    err = errors_for(session, env_path, truth, "default")
    assert err.max() < TARGET["default"], np.array2string(100 * err, precision=2)


def test_default_rough_metal_within_target_over_all_its_pixels(session, env_path):
    """The rough metal (r 0.75) is the cell nearest the target, so it is judged on every pixel
    at N.V 0.3 - 0.95 (1387), not a sample: the one-read ramps measured 5.23 % there, the lobe
    table with the core read twice 4.46 %."""
    spec = ibl_spec(env_path)
    res = session.render(spec)
    aov = res.aov
    i, j = 2, 3
    ys, xs = np.nonzero((aov["row"] == i) & (aov["col"] == j) & (aov["ndotv"] >= 0.3) & (aov["ndotv"] <= 0.95))
    n = aov["normal"][ys, xs].astype(np.float64)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    v = frame_grid(spec).position - (sphere_centers(spec)[i, j] + spec.sphere_radius * n)
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    want = oracle.ibl_integral(n, v, np.asarray(spec.base_color), spec.material_array("metallic")[i, j],
                               spec.material_array("roughness")[i, j], ENV)
    err = np.abs(res.hdr[ys, xs] / want - 1).mean()
    assert ys.size > 1000 and err < TARGET["default"], (ys.size, 100 * err)


POLISHED_METAL = (2, 0)                              # metallic 1, r 0 (clamped to 0.045)


def test_default_polished_metal_reads_the_mirror_level(session, env_path, truth):
    """An r = 0 lobe is one direction, so the split sum is exact there but for the prefilter's
    level 0: the default must be as close as the prefiltered levels are to float64 on the high
    preset (LEVEL_BOUND). Reading the level at lod = r (levels - 1) blended in 20 % of the
    r = 0.2 level and measured 0.73 %; the blend by the lobe's second moment reads 0.12 %."""
    err = errors_for(session, env_path, truth, "default")[POLISHED_METAL]
    assert err < LEVEL_BOUND["high"], 100 * err


def test_high_within_target_on_every_cell(session, env_path, truth):
    err = errors_for(session, env_path, truth, "high")
    assert err.max() < TARGET["high"], np.array2string(100 * err, precision=2)


def test_sampled_path_converges_with_the_sample_count(session, env_path, truth, monkeypatch):
    """The per-pixel path tends to the exact integral: the mean and the worst cell error fall
    as the sample count grows (measured 3.0 / 1.5 / 0.65 % mean at 16 / 64 / 256)."""
    base = QUALITY_PRESETS["high"]
    means, worst = [], []
    for count in (16, 64, 256):
        monkeypatch.setitem(QUALITY_PRESETS, "high", dataclasses.replace(base, ibl_pixel_samples=count))
        err = errors_for(session, env_path, truth, "high")
        means.append(err.mean())
        worst.append(err.max())
    assert means[0] > means[1] > means[2] and worst[0] > worst[1] > worst[2], (means, worst)
    assert means[2] < means[0] / 3


def test_split_sum_corrections_help_rough_metals(session, env_path, truth, monkeypatch):
    """Each correction of the split-sum lookup, ablated on the metal row at r >= 0.5 where the
    split sum is worst: leaning toward N (Frostbite's lerp, then the moment fit) beats reading
    along R (measured mean 24 / 9.6 / 4.9 %), the two-lobe lookup beats one lobe (3.7 %), and
    its table over r and N.V with the core read twice beats the ramps it replaced."""
    base = QUALITY_PRESETS["default"]
    rough_metal = {}
    for mode, two_lobe, two_tap in (("none", False, False), ("frostbite", False, False), ("moments", False, False),
                                    ("moments", True, False), ("moments", True, True)):
        monkeypatch.setitem(QUALITY_PRESETS, "default", dataclasses.replace(
            base, ibl_dominant_dir=mode, ibl_two_lobe=two_lobe, ibl_two_tap=two_tap))
        rough_metal[mode, two_lobe, two_tap] = errors_for(session, env_path, truth, "default")[2, 2:]
    none, frostbite, moments, two, table = (rough_metal[k] for k in rough_metal)
    assert (frostbite < none).all() and moments.mean() < frostbite.mean(), rough_metal
    assert two.mean() < moments.mean(), rough_metal
    assert table.mean() < two.mean(), rough_metal


def test_sampled_path_keeps_the_furnace(session):
    """Under a uniform environment the sampled path's ratio estimators return the radiance
    itself, so `high` reads the split sum's furnace values (shading_model.furnace_expected) through
    its DFG table, within what that table allows (test_chart.FurnaceBudget). One ray per pixel
    (no anti-aliasing): each pixel is the shading of its centre's N.V."""
    spec = make_spec(env="uniform", lights="none", ground=False, ao=False, shadows=False, rows=3, cols=5,
                     width=160, height=96, quality="high", stage="shared", tonemap="none", antialias=False)
    res = session.render(spec)
    aov = res.aov
    mask = (aov["row"] >= 0) & (aov["ndotv"] >= 0.2)
    FurnaceBudget(session, spec, res, mask, base_color=spec.base_color).check()


if __name__ == "__main__":   # the table behind the targets: python tests/test_ibl_accuracy.py
    import tempfile
    from pathlib import Path
    from sdfpbr.gpu.session import Session
    from sdfpbr.cache import ArrayCache
    session = Session(cache=ArrayCache(tempfile.mkdtemp()))
    path = Path(tempfile.mkdtemp()) / "lobe_sky.npy"
    np.save(path, ENV.to_equirect(1024))
    spec = ibl_spec(path)
    px = pick_pixels(spec, session.render(spec).aov, per_band=40)
    want = oracle.ibl_integral(px["n"], px["v"], np.asarray(spec.base_color), px["m"], px["r"], ENV)
    for q in ("draft", "default", "high"):
        err = errors_for(session, path, (px, want), q)
        print(f"{q}: mean {100 * err.mean():.2f} %, worst cell {100 * err.max():.2f} % "
              f"(rows metallic {spec.axis_values('y')}, columns r {spec.axis_values('x')})")
        print(np.array2string(100 * err, precision=2))


# ---- the ground's table -------------------------------------------------------------------

def ground_view_directions(size):
    """The view direction of each texel of the ground's table (ground_ibl.glsl's octahedral
    map of the upper hemisphere, written again here)."""
    u = (np.arange(size) + 0.5) / size
    dx, dy = np.meshgrid(2 * u - 1, 2 * u - 1, indexing="xy")
    x, z = 0.5 * (dx + dy), 0.5 * (dx - dy)
    v = np.stack([x, np.maximum(1 - np.abs(x) - np.abs(z), 0), z], -1)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def ground_table_errors(session, env_path, quality, count=300):
    """|table / float64 integral - 1| at ``count`` texels whose view is 5 - 85 degrees from
    the horizon (the floor a chart shows), and the same for the split sum's formula at them."""
    spec = make_spec(ibl_spec(env_path, quality), ground=True)
    with session:
        plan = render_plan(spec)
        env = make_environment(session.ctx, chart_frame(spec))
        lighting = session.ibl.lighting(env, plan.ibl)
        dfg = session.ibl.dfg(plan)
        uniforms = {"u_ground_color": spec.ground_color, "u_ground_roughness": spec.ground_roughness}
        ground = session.ibl.ground_table(plan, lighting, dfg, uniforms)
        size = plan.ibl.ground_table_size
        table = np.frombuffer(ground.texture.read(), np.float32).reshape(size, size, 4)[..., :3]
    v = ground_view_directions(size).reshape(-1, 3)
    keep = np.nonzero((v[:, 1] > np.sin(np.radians(5))) & (v[:, 1] < np.sin(np.radians(85))))[0]
    idx = np.random.default_rng(5).choice(keep, count, replace=False)
    up = np.tile([0.0, 1.0, 0.0], (count, 1))
    want = oracle.ibl_integral(up, v[idx], np.asarray(spec.ground_color), 0.0, spec.ground_roughness, ENV)
    got = table.reshape(-1, 3)[idx].astype(np.float64)
    return np.abs(got / want - 1).mean(-1), v[idx]


@pytest.mark.parametrize("quality", ["draft", "default", "high"])
def test_ground_table_matches_float64_integral(session, env_path, quality):
    """The ground's IBL table against the exact integral over the view directions a floor is
    seen at: every texel within the high preset's target (1.5 %) on every preset (measured
    0.3 % mean, 0.9 % worst; the split sum it replaces put the default chart's far floor up
    to 8 % low, and SH9 diffuse alone 2 % low)."""
    err, _ = ground_table_errors(session, env_path, quality)
    assert err.max() < TARGET["high"], (err.mean(), err.max())


def test_the_lobe_table_is_what_its_fit_writes():
    """shaders/ibl_lobe_table.glsl is `python -m sdfpbr.oracle.lobe_fit`'s output, not edited by
    hand: one node fitted again (r 0.5, N.V 0.5; ~30 s of float64) reads the table's values,
    and on its held-out skies the table beats the one-read ramps it replaced."""
    import re
    from sdfpbr.oracle import lobe_fit
    from sdfpbr.shading.compose import shader_dir
    text = (shader_dir() / "ibl_lobe_table.glsl").read_text()

    def array(name):
        return [float(x) for x in re.search(rf"{name}\[\d+\] = float\[\]\(([^)]*)\)", text).group(1).split(",")]
    i, j = lobe_fit.R_NODES.index(0.5), lobe_fit.MU_NODES.index(0.5)
    node = lobe_fit.fit_node((i, j, 0.5, 0.5))
    k = i * len(lobe_fit.MU_NODES) + j
    got = (array("LOBE_TABLE_DELTA")[k], array("LOBE_TABLE_CORE")[k], array("LOBE_TABLE_TAIL")[k])
    np.testing.assert_allclose(got, (node["delta"], node["core"], node["tail"]), atol=5e-4)
    assert node["table"] < node["ramps"], node
