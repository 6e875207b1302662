"""GLSL against the float64 numpy model and docs/model.md's test vectors: BRDF, DFG LUT, tone mappers, IBL."""
import shutil

import numpy as np
import pytest

from sdfpbr.oracle import dfg_bake, display, shading_model
from sdfpbr.shading.compose import shader_dir
from sdfpbr.shading.plan import chart_frame, compose_program as compose, display_options, render_plan
from sdfpbr.gpu.programs import set_uniforms
from sdfpbr.spec.chart_spec import QUALITY_PRESETS, TONEMAPPERS, make_spec

from helpers import dfg_read, rounding_bound

BRDF_KERNEL = """
#include "common.glsl"
#include "ggx.glsl"
#include "visibility.glsl"
#include "brdf.glsl"
layout(local_size_x = 64) in;
struct Case { vec4 n; vec4 v; vec4 l; vec4 base_metal; vec4 rough_e; };
layout(std430, binding = 0) readonly buffer Cases { Case cases[]; };
layout(std430, binding = 1) writeonly buffer Results { vec4 results[]; };
uniform int u_count;
void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i >= u_count) return;
    Case c = cases[i];
    Material m = make_material(c.base_metal.rgb, c.base_metal.a, c.rough_e.x);
    float n_dot_v = max(dot(c.n.xyz, c.v.xyz), MIN_N_DOT_V);
    results[i] = vec4(brdf_cos(m, c.n.xyz, c.v.xyz, c.l.xyz, n_dot_v, c.rough_e.z, c.rough_e.y), 0.0);
}
"""


def _kernel_root(tmp_path):
    root = tmp_path / "shaders"
    shutil.copytree(shader_dir(), root)
    (root / "brdf_test_main.glsl").write_text(BRDF_KERNEL)
    return root


def _random_unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("model", ["gltf", "schlick-ggx"])
@pytest.mark.parametrize("multiscatter", [False, True])
@pytest.mark.parametrize("disc_deg", [0.0, 6.0])
def test_glsl_brdf_matches_float64_mirror(ctx, session, tmp_path, model, multiscatter, disc_deg):
    """disc_deg > 0: l is the centre of a disc light, shaded at its representative point."""
    rng = np.random.default_rng(7)
    n_cases = 4096
    n = _random_unit(rng, n_cases)
    v = _random_unit(rng, n_cases)
    v = np.where((v * n).sum(1, keepdims=True) < 0, -v, v)       # view above the surface
    l = _random_unit(rng, n_cases)
    base = rng.uniform(0, 1, (n_cases, 3))
    metal = rng.choice([0.0, 0.3, 1.0], n_cases)
    rough = rng.choice([0.0, 0.045, 0.2, 0.5, 0.8, 1.0], n_cases)
    e = rng.uniform(0.3, 1.0, n_cases)
    cases = np.zeros((n_cases, 5, 4), np.float32)
    cases[:, 0, :3], cases[:, 1, :3], cases[:, 2, :3] = n, v, l
    cases[:, 3, :3], cases[:, 3, 3] = base, metal
    cases[:, 4, 0], cases[:, 4, 1], cases[:, 4, 2] = rough, e, np.radians(disc_deg)
    source = compose("brdf_test_main.glsl", {"BRDF_MODEL": model.replace("-", "_"), "MULTISCATTER": multiscatter},
                     root=_kernel_root(tmp_path))
    program = session.programs.compute(source)
    inbuf = ctx.buffer(cases.tobytes())
    outbuf = ctx.buffer(reserve=n_cases * 16)
    inbuf.bind_to_storage_buffer(0)
    outbuf.bind_to_storage_buffer(1)
    set_uniforms(program, {"u_count": n_cases})
    program.run((n_cases + 63) // 64)
    ctx.memory_barrier()
    got = np.frombuffer(outbuf.read(), np.float32).reshape(n_cases, 4)[:, :3]
    def brdf_cos(n, v, l, base, metal, rough, e, disc):   # disc: one radius for every case
        return shading_model.brdf(n, v, l, base, metal, rough, model=model, multiscatter=multiscatter, e_spec=e,
                           disc_angular_radius=float(disc[0])) * np.clip((n * l).sum(1), 0, None)[:, None]
    # The disc's radius an argument too: its rounding and the driver's sin of it enter the bound.
    args = (n, v, l, base, metal, rough, e, np.full(n_cases, np.radians(disc_deg)))
    want = brdf_cos(*args)
    assert np.isfinite(got).all()
    assert (np.abs(got - want) <= rounding_bound(brdf_cos, args)).all()   # back faces: exactly 0
    assert (want > 0.5).any() and (want == 0).any()   # the cases reach highlights and back faces


@pytest.mark.parametrize("model", ["gltf", "schlick-ggx"])
def test_dfg_lut_is_its_rule_in_float32(ctx, session, model):
    """The bake (dfg_main.glsl) evaluates its quadrature rule as oracle.dfg_bake does in
    float64, sample for sample: the two tables differ by float32 alone, within Higham's bound
    for the bake's sums of non-negative terms (dfg_bake.float32_bound). A change of the rule
    in one and not the other fails it -- e.g. sampling in u instead of t = sqrt(1 - u), which
    at N.V -> 0 moves the grazing column by 6.8e-3 -- as does a driver whose float32 strays
    beyond it (an H100's rounding once tilted h at r = 0 by 2.7e-2)."""
    size, samples = 16, 4096
    source = compose("dfg_main.glsl", {"BRDF_MODEL": model.replace("-", "_")})
    gpu = session.ibl.compute_dfg_table(source, size, samples).astype(np.float64)
    grid = np.arange(size) / (size - 1)
    mu, r = np.maximum(np.tile(grid, size), shading_model.MIN_N_DOT_V), np.repeat(grid, size)
    a, b, c, _ = dfg_bake.dfg_rule(mu, r, samples, model)
    gamma = dfg_bake.float32_bound(samples)
    got = gpu.reshape(-1, 4)
    assert (np.abs(got[:, 0] - a) <= gamma * (a + b)).all()
    assert (np.abs(got[:, 1] - b) <= gamma * (a + b)).all()
    assert (np.abs(got[:, 2] - c) <= gamma).all()     # C's terms are each at most 1
    # With the glTF visibility A + B falls with roughness, as the single-scatter loss grows
    # (Schlick-GGX with k = alpha/2 is not monotonic, in the float64 quadrature as well).
    if model == "gltf":
        assert (np.diff(gpu[:, 2:, 0] + gpu[:, 2:, 1], axis=0) < 2e-3).all()


@pytest.mark.parametrize("preset", ["draft", "default", "high"])
def test_dfg_rule_bias_is_below_half_an_8bit_step(preset):
    """The rule's own error (oracle.dfg_bake against shading_model.dfg_integrate, both float64) at a
    preset's table size and sample count, on every row the chart reads (from the one below the
    roughness clamp), as white furnace pixels take it: a dielectric and a metal, compensated or
    not (shading_model.furnace_from_dfg with the rule's A, B, C against the integral's), each within
    half an 8-bit step of sRGB at its value (display.srgb_half_step): every preset's table is
    invisible in an 8-bit image (draft's had 256 samples, 1.67 half steps off; 512 now). (Rows
    below the clamp are never read; there the mirror's delta-lobe shortcut for alpha < 1e-4
    ignores masking at grazing N.V.)"""
    from sdfpbr.spec.material import MIN_PERCEPTUAL_ROUGHNESS
    q = QUALITY_PRESETS[preset]
    grid = np.arange(q.dfg_size) / (q.dfg_size - 1)
    rows = grid[int(np.floor(MIN_PERCEPTUAL_ROUGHNESS * (q.dfg_size - 1))):]
    for chunk in np.array_split(rows, max(1, rows.size // 8)):
        mu, r = np.maximum(np.tile(grid, chunk.size), shading_model.MIN_N_DOT_V), np.repeat(chunk, grid.size)
        rule = dfg_bake.dfg_rule(mu, r, q.dfg_samples)[:3]
        exact = shading_model.dfg_integrate(mu, r)
        for metallic in (0.0, 1.0):
            for multiscatter in (True, False):
                want = shading_model.furnace_from_dfg(*exact, np.ones(3), metallic, multiscatter)[:, 0]
                got = shading_model.furnace_from_dfg(*rule, np.ones(3), metallic, multiscatter)[:, 0]
                assert (np.abs(got - want) <= display.srgb_half_step(want)).all(), (metallic, multiscatter)


def test_dfg_rule_bias_falls_with_samples():
    """The rule converges to the integral, faster than a Monte Carlo's 1/sqrt(N): four times
    the samples take the worst texel's error down more than twofold away from the grazing
    column, where t = sqrt(1 - u) makes the integrand smooth (measured 5.5x per fourfold)."""
    grid = np.arange(16) / 15
    mu, r = np.maximum(np.tile(grid[1:], 16), shading_model.MIN_N_DOT_V), np.repeat(grid, 15)
    exact = np.stack(shading_model.dfg_integrate(mu, r), -1)
    worst = [np.abs(np.stack(dfg_bake.dfg_rule(mu, r, n)[:3], -1) - exact).max(0) for n in (1024, 4096)]
    assert (worst[1] * 2 < worst[0]).all()


def test_default_lut_hits_reference_vectors(ctx, session):
    """The LUT the chart uses, sampled bilinearly as dfg.glsl does, against docs/model.md's test vectors."""
    q = QUALITY_PRESETS["default"]
    source = compose("dfg_main.glsl", {"BRDF_MODEL": "gltf"})
    table = session.ibl.compute_dfg_table(source, q.dfg_size, q.dfg_samples)

    def lookup(mu, r):
        return [t[0] for t in dfg_read(table.astype(float), np.array([mu]), np.array([r]))[:2]]
    for r, mu, e, a, b in [(0.25, 0.25, 0.96157, 0.75803, 0.20354), (0.5, 0.5, 0.85726, 0.83492, 0.02235),
                           (0.75, 0.5, 0.66318, 0.65469, 0.00848), (1.0, 0.5, 0.45069, 0.44771, 0.00299),
                           (1.0, 1.0, 1 - np.log(2), 0.30682, 0.00003)]:
        got_a, got_b = lookup(mu, r)
        assert abs(got_a + got_b - e) < 6e-3, (r, mu)
        assert abs(got_b - b) < 6e-3, (r, mu)


TONEMAP_TABLE = {  # docs/model.md, tone mapping: gray in 0.18, 1, 4
    "reinhard": (0.152542, 0.5, 0.8),
    "aces": (0.266899, 0.803797, 0.973417),
    "aces-hill": (0.105591, 0.619115, 0.909014),
    "neutral": (0.14, 0.869091, 0.983256),
}


@pytest.mark.parametrize("name", TONEMAPPERS)
def test_display_program_matches_reference(ctx, session, name):
    import moderngl
    values = np.array([0.18, 1.0, 4.0, 0.001, 0.01, 0.5], np.float32)
    hdr = np.zeros((1, len(values), 4), np.float32)
    hdr[0, :, :3] = values[:, None] * np.array([1.0, 1.0, 1.0])
    hdr[0, 5, :3] = (0.9, 0.3, 0.05)                      # a coloured input too
    hdr[..., 3] = 1
    # pixels, no cells
    src = compose("display_main.glsl", display_options(make_spec(tonemap=name, cell_borders=False)))
    program = session.programs.fragment(src)
    tex = ctx.texture((len(values), 1), 4, hdr.tobytes(), dtype="f4")
    target = ctx.texture((len(values), 1), 4, dtype="f4")
    fbo = ctx.framebuffer([target])
    fbo.use()
    tex.use(0)
    set_uniforms(program, {"u_radiance": 0, "u_exposure_scale": 1.0, "u_reinhard_white": 4.0})
    ctx.vertex_array(program, []).render(moderngl.TRIANGLES, vertices=3)
    out = np.frombuffer(target.read(), np.float32).reshape(len(values), 4)[:, :3]
    linear_out = display.srgb_eotf(out)
    want = display.tonemap(hdr[0, :, :3].astype(np.float64), name)
    np.testing.assert_allclose(out, display.srgb_oetf(want), atol=2e-5)
    if name in TONEMAP_TABLE:
        np.testing.assert_allclose(linear_out[:3, 1], TONEMAP_TABLE[name], atol=2e-5)
        assert np.ptp(linear_out[:3], axis=1).max() < 2e-5        # gray stays gray
    # The encode is the piecewise sRGB curve: 0.18 -> 0.461356 when the tone map is identity.
    if name == "none":
        np.testing.assert_allclose(out[[0, 4, 3], 0], [0.461356, 0.099853, 0.012920], atol=2e-6)


def test_uniform_environment_bakes_to_one_and_irradiance_pi(ctx, session):
    from sdfpbr.gpu.ibl import make_environment
    spec = make_spec(env="uniform", lights="none", quality="draft")
    env = make_environment(session.ctx, chart_frame(spec))
    ibl = render_plan(spec).ibl
    lighting = session.ibl.lighting(env, ibl)
    levels = [session.ibl.read_level(ibl, lighting, k) for k in range(lighting.lods + 1)]
    for level in levels:
        np.testing.assert_allclose(level[..., :3], 1.0, atol=2e-3)
    # E(n) = pi for L = 1: only the constant band survives.
    np.testing.assert_allclose(lighting.sh[0], np.pi, rtol=1e-3)
    np.testing.assert_allclose(lighting.sh[1:], 0.0, atol=2e-3)
    # The floor's irradiance / pi: the upper hemisphere's cosine-weighted integral over pi, 1,
    # as the bake sums it: at each texel's centre (the midpoint rule, its error second order in
    # the texel's size: 0.13 % at 16² a face, 0.03 % at 32²), the same sum in float64 here.
    size = min(ibl.sh_size, ibl.env_bake_size)
    c = (np.arange(size) + 0.5) / size * 2 - 1
    s, t = np.meshgrid(c, c)
    h = 1.0 / size

    def area(x, y):
        return np.arctan2(x * y, np.sqrt(x * x + y * y + 1))
    solid = area(s - h, t - h) - area(s - h, t + h) - area(s + h, t - h) + area(s + h, t + h)
    up = [-t, -t, np.ones_like(s), -np.ones_like(s), -t, -t]   # y of each face's texels before normalising
    norm = np.sqrt(1 + s * s + t * t)
    midpoint = sum((np.maximum(y, 0) / norm * solid).sum() for y in up) / np.pi
    np.testing.assert_allclose(lighting.floor_irradiance_over_pi, midpoint, rtol=1e-5)
    assert abs(midpoint - 1.0) < 0.5 / size ** 2


def test_studio_sh_matches_float64_projection(ctx, session):
    """SH9 from the GPU against a float64 projection of the same baked cubemap level."""
    from sdfpbr.gpu.ibl import make_environment
    from sdfpbr.spec.chart_spec import make_spec
    spec = make_spec(env="studio", quality="draft")
    env = make_environment(session.ctx, chart_frame(spec))
    ibl = render_plan(spec).ibl
    lighting = session.ibl.lighting(env, ibl)
    # Reference: sample the environment function through a fine bake read back at level 0.
    level0 = session.ibl.read_level(ibl, lighting, 0).astype(np.float64)[..., :3]
    size = level0.shape[1]
    c = (np.arange(size) + 0.5) / size * 2 - 1
    s, t = np.meshgrid(c, c)
    one = np.ones_like(s)
    dirs = [np.stack(d, -1) for d in ((one, -t, -s), (-one, -t, s), (s, one, t),
                                      (s, -one, -t), (s, -t, one), (-s, -t, -one))]
    dirs = np.stack(dirs)
    dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
    solid = (2 / size) ** 2 / (1 + s ** 2 + t ** 2) ** 1.5
    x, y, z = dirs[..., 0], dirs[..., 1], dirs[..., 2]
    basis = [0.282095 * one, 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y, 1.092548 * y * z,
             0.315392 * (3 * z * z - 1), 1.092548 * x * z, 0.546274 * (x * x - y * y)]
    band = [np.pi] + [2 * np.pi / 3] * 3 + [np.pi / 4] * 5
    consts = [0.282095, 0.488603, 0.488603, 0.488603, 1.092548, 1.092548, 0.315392, 1.092548, 0.546274]
    ref = np.array([(level0 * (b * solid)[..., None]).sum((0, 1, 2)) * band[k] * consts[k]
                    for k, b in enumerate(basis)])
    # The GPU projects a coarser mip of a finer bake; agreement to a few percent of the DC term.
    assert np.abs(lighting.sh - ref).max() < 0.03 * ref[0].max()
    assert ref[0].min() > 0
    # The floor's irradiance / pi, summed over the texels with max(y, 0): the mips differ only
    # in the texels the horizon crosses, whose cosine is under half a texel's angle (1/32 rad at
    # the sum's 32², a band of them 2 pi x 1/16 sr), so under 1 % of the sky's E / pi.
    floor = (level0 * (np.maximum(y, 0.0) * solid)[..., None]).sum((0, 1, 2)) / np.pi
    np.testing.assert_allclose(lighting.floor_irradiance_over_pi, floor, rtol=0.01)
