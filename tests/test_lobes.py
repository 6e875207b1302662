"""The KHR lobes (clearcoat, sheen, specular/ior, emission) in the chart shader, the reference
and the float64 model (sdfpbr.oracle.lobes): GLSL against float64 per lobe, the reference's
furnace against the mirror's directional albedo, the chart's split-sum furnace against the
mirror, and a scene that does not use a lobe does not compile it."""
import dataclasses
import functools
import shutil

import numpy as np
import pytest
from helpers import (PROGRAM_RTOL, REFERENCE_FURNACE, chart_dfg_table, check_converged, dfg_read_error, interior,
                     luminance, primary_hits, rounding_bound, table_bias)

from sdfpbr.gpu.programs import set_uniforms
from sdfpbr.oracle import ibl_integral as ibl_oracle
from sdfpbr.oracle import dfg_bake, display, lobes, shading_model
from sdfpbr.shading.compose import shader_dir
from sdfpbr.shading.plan import compose_program, render_plan
from sdfpbr.spec.chart_spec import Light, make_spec
from sdfpbr.spec.material import LOBES, Material
from sdfpbr.devtools.energy import furnace_spec
from sdfpbr.features.reference import compensation_table, render_reference

# One material per lobe, each with the core material under it (a rough dielectric base, so
# the lobes' effect on the base is visible), and the spec keys that give it to a chart.
LOBE_MATERIALS = {
    "clearcoat": (Material(base_color=(0.8, 0.3, 0.2), roughness=0.6, clearcoat=1.0, clearcoat_roughness=0.25),
                  dict(base_color=(0.8, 0.3, 0.2), roughness=0.6, clearcoat=1.0, clearcoat_roughness=0.25)),
    "sheen": (Material(base_color=(0.3, 0.3, 0.6), roughness=0.5, sheen_color=(1.0, 0.6, 0.8), sheen_roughness=0.4),
              dict(base_color=(0.3, 0.3, 0.6), roughness=0.5, sheen_color=(1.0, 0.6, 0.8), sheen_roughness=0.4)),
    "specular": (Material(base_color=(0.2, 0.5, 0.2), roughness=0.4, ior=2.2, specular=0.7,
                          specular_color=(1.0, 0.6, 0.3)),
                 dict(base_color=(0.2, 0.5, 0.2), roughness=0.4, ior=2.2, specular=0.7,
                      specular_color=(1.0, 0.6, 0.3))),
}
LOBE_OPTIONS = {lobe.name: lobe.option for lobe in LOBES}

KERNEL = """
#include "common.glsl"
#include "ggx.glsl"
#include "visibility.glsl"
#include "dfg.glsl"
#include "brdf.glsl"
layout(local_size_x = 64) in;
struct Case { vec4 n; vec4 v; vec4 l; vec4 e; };
layout(std430, binding = 0) readonly buffer Cases { Case cases[]; };
layout(std430, binding = 1) writeonly buffer Results { vec4 results[]; };
uniform int u_count;
uniform vec4 u_base_metal;
uniform vec4 u_rough;          // roughness, clearcoat, clearcoat roughness, sheen roughness
uniform vec3 u_sheen_color;
uniform vec4 u_specular;       // f0, weight
void main() {
    int i = int(gl_GlobalInvocationID.x);
    if (i >= u_count) return;
    Case c = cases[i];
    Material m = make_material(u_base_metal.rgb, u_base_metal.a, u_rough.x);
#if CLEARCOAT
    m.clearcoat = u_rough.y;
    set_clearcoat_roughness(m, u_rough.z);
    m.clearcoat_normal = c.n.xyz;
#endif
#if SHEEN
    m.sheen_color_linear = u_sheen_color;
    m.sheen_perceptual_roughness = max(u_rough.w, MIN_PERCEPTUAL_ROUGHNESS);
#endif
#if KHR_SPECULAR
    m.specular_f0 = u_specular.rgb;
    m.specular_weight = u_specular.a;
#endif
    float n_dot_v = max(dot(c.n.xyz, c.v.xyz), MIN_N_DOT_V);
    results[i] = vec4(brdf_cos(m, c.n.xyz, c.v.xyz, c.l.xyz, n_dot_v, 0.0, c.e.x), 0.0);
}
"""


@functools.cache
def mirror_albedo(points: int, m: Material, n: int = 64, sheen_scaling: str = "exact") -> np.ndarray:
    """lobes.layered_albedo at np.linspace(0, 1, points), kept for the module: the furnace tests
    of a lobe (the reference's, the chart's at each quality) read the same float64 quadratures,
    seconds each."""
    albedo = lobes.layered_albedo(np.linspace(0.0, 1.0, points), m, n=n, sheen_scaling=sheen_scaling)
    albedo.setflags(write=False)
    return albedo


def _units(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("lobe", sorted(LOBE_MATERIALS))
def test_glsl_layers_match_the_float64_mirror(ctx, session, tmp_path, lobe):
    """brdf_cos with the lobe composed in, at 4096 random directions, against
    sdfpbr.oracle.lobes.layered_brdf, within float32's bound for each case
    (test_shading.rounding_bound). The sheen's albedo scaling reads E_s from a 128² table (the
    reference's) bilinearly where the mirror integrates it: that read's error, at N.V and at
    N.L, on the base layer's light, is allowed too."""
    m, _ = LOBE_MATERIALS[lobe]
    rng = np.random.default_rng(11)
    count = 4096
    n = _units(rng, count)
    v = _units(rng, count)
    v = np.where((v * n).sum(1, keepdims=True) < 0, -v, v)
    l = _units(rng, count)
    n_dot_v = np.clip((n * v).sum(1), shading_model.MIN_N_DOT_V, 1)
    e = shading_model.single_scatter_albedo(
        n_dot_v, np.full(count, max(m.roughness, shading_model.MIN_PERCEPTUAL_ROUGHNESS)), "gltf")
    cases = np.zeros((count, 4, 4), np.float32)
    cases[:, 0, :3], cases[:, 1, :3], cases[:, 2, :3], cases[:, 3, 0] = n, v, l, e
    root = tmp_path / "shaders"
    shutil.copytree(shader_dir(), root)
    (root / "lobe_test_main.glsl").write_text(KERNEL)
    source = compose_program("lobe_test_main.glsl", {"BRDF_MODEL": "gltf", "MULTISCATTER": True,
                                                     LOBE_OPTIONS[lobe]: True}, root=root)
    program = session.programs.compute(source)
    table = compensation_table("gltf", session.cache, sheen=True)
    dfg = ctx.texture(table.shape[1::-1], 4, np.ascontiguousarray(table).tobytes(), dtype="f4")
    dfg.repeat_x = dfg.repeat_y = False
    inbuf, outbuf = ctx.buffer(cases.tobytes()), ctx.buffer(reserve=count * 16)
    try:
        inbuf.bind_to_storage_buffer(0)
        outbuf.bind_to_storage_buffer(1)
        dfg.use(0)
        f0 = lobes.dielectric_f0(m.ior, m.specular_color)
        set_uniforms(program, {"u_count": count, "u_base_metal": (*m.base_color, m.metallic), "u_dfg": 0,
                               "u_rough": (m.roughness, m.clearcoat, m.clearcoat_roughness, m.sheen_roughness),
                               "u_sheen_color": m.sheen_color, "u_specular": (*f0, m.specular)})
        program.run((count + 63) // 64)
        ctx.memory_barrier()
        got = np.frombuffer(outbuf.read(), np.float32).reshape(count, 4)[:, :3]
    finally:
        for obj in (inbuf, outbuf, dfg):
            obj.release()
    def layered_cos(n, v, l, e, material=m):
        return lobes.layered_brdf(n, v, l, material, e_spec=e) * np.clip((n * l).sum(1), 0, None)[:, None]
    want = layered_cos(n, v, l, e)
    assert np.isfinite(got).all()
    bound = rounding_bound(layered_cos, (n, v, l, e))
    if lobe == "sheen":
        # The kernel reads E_s from the table (bilinear, GPUs holding the filter's fractions in
        # 8 bits); the mirror integrates it. The base's scaling min(1 - c E_s(N.V), 1 - c E_s(N.L))
        # moves by c times the larger read error, on the base layer's light.
        r_s = max(m.sheen_roughness, shading_model.MIN_PERCEPTUAL_ROUGHNESS)
        n_dot_l = np.maximum((n * l).sum(1), shading_model.MIN_N_DOT_V)
        table64 = table.astype(np.float64)
        read_error = 0.0
        for x in (n_dot_v, np.where((n * l).sum(1) > 0, n_dot_l, 1.0)):
            rs = np.full(count, r_s)
            read_error = np.maximum(read_error, dfg_read_error(table64, x, rs, lobes.sheen_albedo(x, rs), 3))
        base_layer = layered_cos(n, v, l, e, dataclasses.replace(m, sheen_color=(0.0, 0.0, 0.0)))
        bound = bound + base_layer * max(m.sheen_color) * read_error[:, None]
    assert (np.abs(got - want) <= bound).all()
    assert (want > 0.3).any() and (want == 0).any()


@pytest.mark.parametrize("lobe", sorted(LOBE_MATERIALS))
def test_reference_furnace_matches_the_mirror_per_lobe(session, lobe):
    """Under the uniform environment with one bounce, each pixel of the reference integrates
    f cos over the hemisphere: the float64 directional albedo of the layered material."""
    m, keys = LOBE_MATERIALS[lobe]
    spec = make_spec(**{**REFERENCE_FURNACE, **keys, "metallic": 0.0, "antialias": False})
    res = render_reference(spec, samples=256, max_bounces=1, seed=5, session=session)
    hits = primary_hits(spec)
    mask = interior(spec, hits, 0.15)
    assert mask.sum() > 500 and res.non_finite == 0
    grid = np.linspace(0.0, 1.0, 257)
    albedo = mirror_albedo(grid.size, m)
    ndotv = (hits[3] * hits[4]).sum(-1)
    want = np.stack([np.interp(ndotv, grid, albedo[:, c]).mean(-1) for c in range(3)], -1)
    check_converged(luminance(res.hdr)[mask], luminance(want)[mask], res.stderr[mask],
                    bias=table_bias(session, spec, hits, luminance(want), sheen=lobe == "sheen")[mask])


def sheen_diffuse_scaling_error(c, e_view, sheen_roughness):
    """lobes_ibl.glsl's sheen_diffuse_scaling -- the cosine mean over N.L of min(1 - c E_s(N.V),
    1 - c E_s(N.L)) by 8-point Gauss-Legendre in u = N.L^2 -- against the integral, both with
    the float64 E_s: the rule's error, against a 4000-point midpoint rule plus that rule's own
    step to 2000 points (the min's kink makes it first order)."""
    nodes, weights = np.polynomial.legendre.leggauss(8)
    u8, w8 = 0.5 * (nodes + 1.0), 0.5 * weights

    def mean_over(u, w):
        e_l = lobes.sheen_albedo(np.maximum(np.sqrt(u), shading_model.MIN_N_DOT_V), np.full(u.shape, sheen_roughness))
        return (w[None, :] * np.minimum(1.0 - c * e_view[:, None], 1.0 - c * e_l[None, :])).sum(-1)
    fine = [mean_over((np.arange(k) + 0.5) / k, np.full(k, 1.0 / k)) for k in (2000, 4000)]
    return np.abs(mean_over(u8, w8) - fine[1]) + np.abs(fine[1] - fine[0]), u8


def sheen_factorisation_gap(n_dot_v, m, n=64):
    """What the chart's form of the base's diffuse under the sheen leaves out: it scales the
    Lambert weight's integral C by the scaling's cosine mean S, where the spec's form integrates
    their product: |int (1 - F) cos / pi scale dl - C S|, per N.V, on a Gauss-Legendre product
    grid (within 1e-7 of twice its order)."""
    r_s = max(m.sheen_roughness, shading_model.MIN_PERCEPTUAL_ROUGHNESS)
    shade = max(m.sheen_color)
    x, w = shading_model.gauss_legendre01(n)
    n_dot_l, phi = x, 2.0 * np.pi * x
    e_v = lobes.sheen_albedo(n_dot_v, np.full(n_dot_v.shape, r_s))
    e_l = lobes.sheen_albedo(np.maximum(n_dot_l, shading_model.MIN_N_DOT_V), np.full(n, r_s))
    scale = np.minimum(1.0 - shade * e_v[:, None], 1.0 - shade * e_l[None, :])
    v_dot_l = (np.sqrt(1.0 - n_dot_v ** 2)[:, None, None] * np.sqrt(1.0 - n_dot_l ** 2)[None, :, None]
               * np.cos(phi)[None, None, :] + n_dot_v[:, None, None] * n_dot_l[None, :, None])
    f0 = max(lobes.dielectric_f0(m.ior, m.specular_color))
    fresnel = m.specular * (f0 + (1.0 - f0)
                            * shading_model.fresnel_weight(np.sqrt(np.maximum(0.5 * (1.0 + v_dot_l), 0.0))))
    kernel = (1.0 - fresnel) * (n_dot_l * w)[None, :, None] / np.pi * (2.0 * np.pi * w)[None, None, :]
    cosine_mean = (scale * (2.0 * n_dot_l * w)[None, :]).sum(1)
    return np.abs((kernel * scale[:, :, None]).sum((1, 2)) - kernel.sum((1, 2)) * cosine_mean)


def sheen_specular_rule(n_dot_v, m):
    """lobes_ibl.glsl's sheen_specular_scaling in float64 (..., 3): 1 - c max(E_s(N.V), E_s(N.L))
    averaged over the base's GGX lobe by its 8 x 4 Gauss-Legendre product over the
    visible-normal square, the azimuth on one side of the N-V plane, each node weighted by
    Vis N.L F (Heitz 2018's map of the square to half vectors, written again here), with the
    float64 E_s; and the rule's N.L (..., 32) with each node's share of the weight (..., 32, 3)."""
    mu = np.clip(np.asarray(n_dot_v, np.float64), shading_model.MIN_N_DOT_V, 1.0)[:, None]
    r = max(m.roughness, shading_model.MIN_PERCEPTUAL_ROUGHNESS)
    alpha = r * r
    r_s = max(m.sheen_roughness, shading_model.MIN_PERCEPTUAL_ROUGHNESS)
    x8, w8 = shading_model.gauss_legendre01(8)
    x4, w4 = np.polynomial.legendre.leggauss(4)
    u1, u2, w = np.repeat(x8, 4), np.tile(x4 / 4.0, 8), np.repeat(w8, 4) * np.tile(w4, 8)
    sin_v = np.sqrt(1.0 - mu * mu)
    vh = np.stack(np.broadcast_arrays(alpha * sin_v, 0.0 * mu, mu), -1)
    vh = vh / np.linalg.norm(vh, axis=-1, keepdims=True)
    tilted = vh[..., 0] > 0.0   # t1 = (0, 1, 0) off the normal, (1, 0, 0) on it
    t1 = np.where(tilted[..., None], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    t2 = np.cross(vh, t1)
    p1, p2 = np.sqrt(u1) * np.cos(2.0 * np.pi * u2), np.sqrt(u1) * np.sin(2.0 * np.pi * u2)
    s = 0.5 * (1.0 + vh[..., 2])
    p2 = (1.0 - s) * np.sqrt(np.maximum(1.0 - p1 * p1, 0.0)) + s * p2
    nh = p1[..., None] * t1 + p2[..., None] * t2 + np.sqrt(np.maximum(1.0 - p1 * p1 - p2 * p2, 0.0))[..., None] * vh
    h = np.stack(np.broadcast_arrays(alpha * nh[..., 0], alpha * nh[..., 1], np.maximum(nh[..., 2], 0.0)), -1)
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    v_dot_h = sin_v * h[..., 0] + mu * h[..., 2]
    n_dot_l = 2.0 * v_dot_h * h[..., 2] - mu
    lit = n_dot_l > 0.0
    nl = np.where(lit, n_dot_l, 1.0)
    f0 = lobes.dielectric_f0(m.ior, m.specular_color)
    f0_a = (1.0 - m.metallic) * m.specular * f0 + m.metallic * np.asarray(m.base_color)
    f0_b = (1.0 - m.metallic) * m.specular + m.metallic
    fc = shading_model.fresnel_weight(v_dot_h)[..., None]
    weight = np.where(lit, w * shading_model.vis_smith_ggx_correlated(nl, mu, alpha) * nl, 0.0)[..., None] \
        * (f0_a * (1.0 - fc) + f0_b * fc)
    share = weight / weight.sum(1, keepdims=True)
    e_s = np.maximum(lobes.sheen_albedo_interpolated(mu, r_s), lobes.sheen_albedo_interpolated(nl, r_s))
    return 1.0 - max(m.sheen_color) * (share * e_s[..., None]).sum(1), nl, share


@pytest.mark.parametrize("quality", ["default", "high"])
@pytest.mark.parametrize("lobe", sorted(LOBE_MATERIALS))
def test_chart_furnace_matches_the_mirror_per_lobe(session, lobe, quality):
    """The chart's split sum with the layers (lobes_ibl.glsl) under the white furnace, and the
    high preset's per-pixel sampling (the specular's and the sheen's lobes: ratio estimators,
    the furnace's radiance whatever their samples): exact there but for tables and rules,
    against the mirror's albedo with the sheen scaled as the chart scales it: the base's
    diffuse by the spec's exact form (its cosine mean over N.L by an 8-point rule), its
    specular by the simplified form at N.V (split sum) or by the exact form's mean over the
    GGX lobe by an 8 x 4 rule (sampled). The specular's share is what a black base of the same
    material reflects, under either form. Bound, per pixel, from what the chart reads: the DFG
    table's A, B, C at the base's roughness (each entering at most as 2 / E, C as the base
    colour), its E at the coat's (times the coat's weight), E_s at N.V (on the sheen and the
    base it scales) and at the rules' N.L, each rule's own error (the specular's against
    oracle.lobes.sheen_specular_scaling, times the base's specular), the chart's form of the
    sheen's diffuse scaling (the Lambert weight and the scaling averaged apart: 5e-4 at N.V
    0.43), the mirror's albedo (interpolated on its 257-point grid; its quadrature's order),
    and float32. (Not counted: the mirror's own E_s table inside layered_albedo, within 6e-5 of
    the quadrature above N.V 0.05.)"""
    sampled = render_plan(make_spec(quality=quality)).options.get("IBL_METHOD") == "sampled"
    m, keys = LOBE_MATERIALS[lobe]
    spec = furnace_spec(make_spec(**keys, width=96, height=96, rows=1, cols=1, metallic=0.0, quality=quality),
                        white=False)
    res = session.render(spec)
    aov = res.aov
    mask = (aov["row"] == 0) & (aov["ndotv"] >= 0.2)
    assert mask.sum() > 1000
    mu = aov["ndotv"][mask].astype(np.float64)

    def albedo_on(grid, order=64):
        albedo = mirror_albedo(grid.size, m, n=order)
        if lobe == "sheen" and not sampled:
            black = dataclasses.replace(m, base_color=(0.0, 0.0, 0.0))
            albedo = albedo + mirror_albedo(grid.size, black, n=order, sheen_scaling="view") \
                - mirror_albedo(grid.size, black, n=order)
        return albedo
    grid, finer = np.linspace(0.0, 1.0, 257), np.linspace(0.0, 1.0, 513)
    albedo, albedo_finer = albedo_on(grid), albedo_on(finer)
    want = np.stack([np.interp(mu, grid, albedo[:, c]) for c in range(3)], -1)
    want_finer = np.stack([np.interp(mu, finer, albedo_finer[:, c]) for c in range(3)], -1)
    # The mirror's own error: linear interpolation errs at a point up to twice its step to a grid
    # twice as fine (2 (1 - t) at fraction t of a cell); its quadrature, its step to twice the order.
    mirror_error = 2.0 * np.abs(want - want_finer).max(-1) \
        + np.abs(albedo_on(grid, 128) - albedo)[grid >= 0.2 - 1.0 / 256].max()

    table = chart_dfg_table(session, spec)
    base_max = max(m.base_color)
    r = np.full(mu.shape, max(m.roughness, shading_model.MIN_PERCEPTUAL_ROUGHNESS))
    a, b, c = shading_model.dfg_integrate(mu, r)
    core = 2.0 * (dfg_read_error(table, mu, r, a, 0) + dfg_read_error(table, mu, r, b, 1)) / (a + b) \
        + base_max * dfg_read_error(table, mu, r, c, 2)
    bound = core + mirror_error + 1e-5 * (1.0 + want.max(-1))
    if m.clearcoat > 0.0:
        r_c = np.full(mu.shape, max(m.clearcoat_roughness, shading_model.MIN_PERCEPTUAL_ROUGHNESS))
        weight = m.clearcoat * (shading_model.DIELECTRIC_F0 + (1.0 - shading_model.DIELECTRIC_F0)
                                * shading_model.fresnel_weight(mu))
        bound = bound + weight * dfg_read_error(table, mu, r_c, sum(shading_model.dfg_integrate(mu, r_c)[:2]), "E")
    if max(m.sheen_color) > 0.0:
        shade = max(m.sheen_color)
        r_s = max(m.sheen_roughness, shading_model.MIN_PERCEPTUAL_ROUGHNESS)
        e_view = lobes.sheen_albedo(mu, np.full(mu.shape, r_s))
        rule_error, u8 = sheen_diffuse_scaling_error(shade, e_view, r_s)
        nodes = np.sqrt(u8)
        node_error = dfg_read_error(table, nodes, np.full(8, r_s), lobes.sheen_albedo(nodes, np.full(8, r_s)), 3).max()
        view_error = dfg_read_error(table, mu, np.full(mu.shape, r_s), e_view, 3)
        bound = bound + view_error * (shade * base_max + shade) + base_max * (rule_error + shade * node_error) \
            + base_max * sheen_factorisation_gap(mu, m)
        # The sampled path's specular rule: its error against the float64 ratio (and that
        # ratio's own, its step to twice its order) and E_s as read at N.V and at its N.L, each
        # node by its share of the weight, times the base's specular, (f0 A + B) compensated.
        exact = lobes.sheen_specular_scaling(mu, m)
        rule, nodes, share = sheen_specular_rule(mu, m)
        f0 = lobes.dielectric_f0(m.ior, m.specular_color)
        base_specular = m.specular * (f0 * a[:, None] + b[:, None]) * shading_model.energy_compensation(f0, a + b)
        if sampled:
            rule_error = np.abs(rule - exact) + np.abs(lobes.sheen_specular_scaling(mu, m, n=128) - exact)
            node_read = dfg_read_error(table, nodes.ravel(), np.full(nodes.size, r_s),
                                       lobes.sheen_albedo_interpolated(nodes.ravel(), r_s), 3).reshape(nodes.shape)
            e_s_read = (share * np.maximum(node_read, view_error[:, None])[..., None]).sum(1)
            bound = bound + (base_specular * (rule_error + shade * e_s_read)).max(-1)
    got = res.hdr[mask][:, :3].astype(np.float64)
    assert (np.abs(got - want) <= bound[:, None]).all(), (np.abs(got - want).max(-1) / bound).max()
    if lobe == "sheen":   # the two forms of the scaling differ by more than the chart's whole bound,
        # on the base's specular alone too
        simplified = mirror_albedo(grid.size, m, sheen_scaling="view")
        assert np.abs(simplified - albedo)[grid >= 0.2].max() > 2 * bound.max()
        view = 1.0 - shade * lobes.sheen_albedo_interpolated(mu, r_s)
        assert (base_specular * np.abs(view[:, None] - exact)).max() > 2 * bound.max()
        # and the sampled path's rule tells them apart by more than its own error
        assert np.abs(view[:, None] - exact).max() > 4 * np.abs(rule - exact).max()
    core_albedo = mirror_albedo(grid.size, Material(base_color=m.base_color, roughness=m.roughness))
    assert np.abs(albedo - core_albedo).max() > 0.05   # the lobe changes the albedo by far more than the bound


def test_sheen_lut_is_its_rule_and_the_rule_is_float64(session):
    """The chart's DFG bake with SHEEN: its alpha channel is the sheen's albedo E_s by the
    bake's own rule (oracle.dfg_bake) but for float32 (its sums' bound), and that rule is
    within half an 8-bit step of sRGB (display.srgb_half_step) of the float64 E_s wherever the
    sheen's roughness is above its clamp. At the clamp the lobe is a spike at grazing that a
    2048-point rule resolves to 0.63 of a step: held to one step. The float64 E_s is
    lobes.sheen_albedo at 200 points, its own error (its step from 100 points) allowed too."""
    plan = render_plan(make_spec(sheen_color=(1.0, 1.0, 1.0)))
    assert "SHEEN" in dict(plan.dfg.options)
    size, samples = 32, plan.dfg_samples
    with session.ctx:
        table = session.ibl.compute_dfg_table(plan.dfg, size, samples).astype(np.float64)
    grid = np.arange(size) / (size - 1)
    mu, r = np.maximum(np.tile(grid, size), shading_model.MIN_N_DOT_V), np.repeat(grid, size)
    rule = dfg_bake.dfg_rule(mu, r, samples, sheen=True)[3]
    # Float32: each term to its few ulps (dfg_bake.float32_bound), and, where the half vector's
    # cosine comes from 1 - sin^2 near the horizon, the cancellation's absolute ulp at the
    # table's largest entry.
    float32 = dfg_bake.float32_bound(samples) * rule + dfg_bake.FLOAT32_UNIT_ROUNDOFF * rule.max()
    assert (np.abs(table[..., 3].ravel() - rule) <= float32).all()
    exact = lobes.sheen_albedo(mu, r, n=200)
    steps = (np.abs(rule - exact) - np.abs(exact - lobes.sheen_albedo(mu, r, n=100))) / display.srgb_half_step(exact)
    clamped = r <= shading_model.MIN_PERCEPTUAL_ROUGHNESS
    assert (steps[~clamped] <= 1.0).all() and (steps[clamped] <= 2.0).all()


def test_emission_is_added_as_is_and_dimmed_by_a_coat(session):
    """A black furnace with no lights: each emissive pixel is emissive x strength; under a
    clearcoat, less the coat's reflectance towards the viewer (coated_emission)."""
    base = dict(env="black", lights="none", ground=False, ao=False, rows=1, cols=2, width=96, height=48,
                emissive=(1.0, 0.5, 0.25), emissive_strength=2.0, antialias=False, x_axis="clearcoat",
                x_values=(0.0, 1.0))
    res = session.render(make_spec(**base))
    aov = res.aov
    for col, coat in ((0, 0.0), (1, 1.0)):
        mask = (aov["col"] == col) & (aov["ndotv"] > 0.05)
        fresnel = 0.04 + 0.96 * (1 - aov["ndotv"][mask].astype(np.float64)) ** 5
        want = np.array([2.0, 1.0, 0.5]) * (1 - coat * fresnel)[:, None]
        np.testing.assert_allclose(res.hdr[mask][:, :3], want, rtol=2e-3, atol=1e-5)


# A clear coat over a white metal of its own roughness is that metal: the coat reflects
# clearcoat F_c and the base, F = 1, reflects the rest, 1 - clearcoat F_c (the spec's
# fresnel_coat). The floor under such a sphere takes its mirror image of the lights and the sky
# in closed form (stage_bounce.glsl) from both layers, so the sum must come out as the bare
# metal's: with the base's image not dimmed by the coat above it, the floor read up to 12 %
# bright. The floor's glossy lobe also reads the sphere itself (floor_lobe.glsl samples): the
# layered split sum, equal to the bare metal's only as closely as the sphere's own pixels are
# (they differ most at its rim, where F_c is large). Each sample's weight (F Vis N.L 2 lambda)
# is at most 1, and the floor's energy compensation at most 1 + f0 (1 / E_min - 1): so the
# floor may move by no more than that times the sphere's largest change (with the coat's
# images left out of those samples, a floor pixel in the studio moved 6.6 %, and this failed).
# `high` is left out: its sampled integrals draw the coat and the base with their own sample
# sets, equal to the bare metal's in expectation only.
@pytest.mark.parametrize("env", ["black", "studio"])
@pytest.mark.parametrize("quality", ["draft", "default"])
def test_a_clear_coat_over_a_white_mirror_leaves_its_floor_as_it_was(session, env, quality):
    sun = Light("directional", direction=(-0.55, 0.65, 0.52), intensity=3.0, angular_radius_deg=2.0)
    spec = dict(rows=1, cols=1, width=128, height=128, env=env, lights=(sun,), labels=False, quality=quality,
                base_color=(1.0, 1.0, 1.0), roughness=0.05, metallic=1.0)
    bare = session.render(make_spec(**spec), hdr=True, aovs=True)
    coated = session.render(make_spec(**spec, clearcoat=1.0, clearcoat_roughness=0.05), hdr=True)
    floor, sphere = bare.aov["coverage"] == 0, bare.aov["coverage"] == 1
    want, got = bare.hdr[floor][:, :3].astype(np.float64), coated.hdr[floor][:, :3].astype(np.float64)
    assert want.max() > 0.1 and floor.sum() > 8000
    sphere_change = np.abs(coated.hdr[sphere][:, :3].astype(np.float64) - bare.hdr[sphere][:, :3]).max()
    e_min = shading_model.single_scatter_albedo(np.array(shading_model.MIN_N_DOT_V),
                                                make_spec(**spec).ground_roughness, "gltf")
    compensation = shading_model.energy_compensation(np.array(shading_model.DIELECTRIC_F0), e_min).max()
    # Two programs (the coat composes in): each rounding that moves is worth 2^-24 of the
    # floor's light, of which the brightest pixel is a bound.
    np.testing.assert_allclose(got, want, rtol=0, atol=PROGRAM_RTOL * want.max() + compensation * sphere_change)


# A sheen over a base that reflects nothing (black, no specular: KHR_materials_specular 0) is
# the sheen alone, whatever the base's roughness. The floor's light from a smooth base comes
# two ways (stage_bounce.glsl: the base's mirror image in closed form, the rest by the bounce
# rays), from a rough one by the rays alone; the sheen's own lobe must reach the floor either
# way. The rays of a smooth base kept only its diffuse: its floor read up to 1.2 % of its
# brightest pixel off the rough base's.
@pytest.mark.parametrize("env", ["black", "studio"])
@pytest.mark.parametrize("quality", ["draft", "default", "high"])
def test_a_sheens_light_on_its_floor_does_not_depend_on_the_base_under_it(session, env, quality):
    sun = Light("directional", direction=(-0.55, 0.65, 0.52), intensity=3.0, angular_radius_deg=2.0)
    spec = dict(rows=1, cols=1, width=128, height=128, env=env, lights=(sun,), labels=False, quality=quality,
                base_color=(0.0, 0.0, 0.0), metallic=0.0, specular=0.0, sheen_color=(1.0, 0.6, 0.8),
                sheen_roughness=0.4)
    rough = session.render(make_spec(**spec, roughness=0.9), hdr=True, aovs=True)
    smooth = session.render(make_spec(**spec, roughness=0.05), hdr=True)
    floor = rough.aov["coverage"] == 0
    want, got = rough.hdr[floor][:, :3].astype(np.float64), smooth.hdr[floor][:, :3].astype(np.float64)
    assert want.max() > 0.1 and floor.sum() > 8000
    np.testing.assert_allclose(got, want, rtol=0, atol=PROGRAM_RTOL * want.max())   # as above


@pytest.mark.parametrize("preset", ["draft", "default", "high"])
def test_the_lobes_scene_renders_finite_under_its_environment(session, preset):
    """Every lobe at once under the environment (the bench's lobes scene): no pixel is NaN or
    infinite, the sphere centres included, where N.V rounds to just over 1 (the specular's
    sheen scaling builds V's tangent part from 1 - N.V^2 there)."""
    from sdfpbr.devtools.bench import suite
    spec = suite.scene_spec("lobes", suite.BenchConfig(width=96, height=96), preset)
    res = session.render(spec)
    assert np.isfinite(res.hdr).all() and res.hdr.min() >= 0.0


def test_a_scene_compiles_only_the_lobes_it_uses():
    default = render_plan(make_spec()).chart
    assert not {lobe.option for lobe in LOBES} & set(dict(default.options))
    assert "d_charlie" not in default.text and "clearcoat_layer" not in default.text
    coat = render_plan(make_spec(clearcoat=0.5)).chart
    assert dict(coat.options).get("CLEARCOAT") and "clearcoat_layer" in coat.text and "d_charlie" not in coat.text
    # Values that change nothing switch nothing on: ior 1.5 with specular 1 is the core f0.
    assert not dict(render_plan(make_spec(ior=1.5, specular=1.0, clearcoat=0.0)).chart.options).get("KHR_SPECULAR")


def test_every_lobe_row_names_what_exists():
    """The lobe table (spec.material LOBES) is read by the plan, the glTF reader, the maps and
    the bake: a row naming a Material field, a map or an option that does not exist would be
    ignored by some of them, not refused."""
    from sdfpbr.shading.maps import MAPS_BY_NAME
    from sdfpbr.shading.plan import SCHEMA
    from sdfpbr.spec.material import COLOR_PARAMS, LOBE_NAMES, PARAMS
    fields = {f.name: f.default for f in dataclasses.fields(Material)}
    for lobe in LOBES:
        assert lobe.option in SCHEMA.switches
        assert not lobe.used(Material())   # the default material needs no lobe
        for extension in lobe.gltf:
            assert extension.name.startswith("KHR_materials_")
            for f in extension.factors:
                assert f.field in fields
                assert np.shape(f.default) == np.shape(fields[f.field])
            for t in extension.textures:
                assert t.map in MAPS_BY_NAME and t.kind in ("channel", "colour", "normal")
                assert MAPS_BY_NAME[t.map].srgb == (t.kind == "colour")
    # Every parameter of a lobe belongs to a row, and every row has a parameter.
    owners = {p.lobe for p in PARAMS if p.lobe} | {lobe for _, lobe, _ in COLOR_PARAMS.values()}
    assert owners == set(LOBE_NAMES)
    # No two textures share a channel of a shared map.
    targets = [(t.map, t.channel[1]) for lobe in LOBES for e in lobe.gltf for t in e.textures if t.kind == "channel"]
    assert len(targets) == len(set(targets))


def sheen_centroid(n_dot_v, sheen_roughness, n=160):
    """(c_n, c_t) of the sheen lobe (shading.sheen) in float64: a Gauss-Legendre product rule
    over the hemisphere (theta_l; phi_l over the half on one side of the N-V plane, doubled)."""
    mu, r = np.broadcast_arrays(np.clip(np.asarray(n_dot_v, np.float64), shading_model.MIN_N_DOT_V, 1.0),
                                np.asarray(sheen_roughness, np.float64))
    shape = mu.shape
    mu = mu.ravel()[:, None, None]
    alpha = np.maximum(r.ravel(), shading_model.MIN_PERCEPTUAL_ROUGHNESS)[:, None, None] ** 2
    x, w = shading_model.gauss_legendre01(n)
    theta, phi = 0.5 * np.pi * x[:, None], np.pi * x[None, :]
    weight = (0.5 * np.pi * w[:, None]) * np.sin(theta) * (np.pi * w[None, :])
    n_dot_l, t_dot_l = np.cos(theta), np.sin(theta) * np.cos(phi)
    sin_v = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    n_dot_h = (mu + n_dot_l) / np.sqrt(np.maximum(2.0 + 2.0 * (sin_v * t_dot_l + mu * n_dot_l), 1e-300))
    f = lobes.d_charlie(n_dot_h, alpha) * lobes.v_sheen(n_dot_l, mu, alpha) * n_dot_l * weight
    e = f.sum(axis=(1, 2))
    c = np.stack([(f * n_dot_l).sum(axis=(1, 2)) / e, (f * t_dot_l).sum(axis=(1, 2)) / e], -1)
    return c.reshape(shape + (2,))


def test_the_sheen_centroid_table_is_the_float64_integral():
    """shading.sheen.SHEEN_CENTROID against the quadrature above (its 5 decimals), and that
    quadrature against a midpoint sum over the whole sphere of directions at three points,
    within the sum's own error (four thirds of its step from 400 to 800 rows: h^2) and the
    quadrature's (its step from 160 to 320 points)."""
    from sdfpbr.shading.sheen import SHEEN_CENTROID, SHEEN_CENTROID_STEPS
    rows, cols = SHEEN_CENTROID_STEPS
    x = np.linspace(0.0, 1.0, rows)
    want = sheen_centroid((1.0 - x * x)[:, None], np.linspace(0.0, 1.0, cols)[None, :])
    np.testing.assert_allclose(np.array(SHEEN_CENTROID), want, atol=6e-6)
    def brute(mu, r, m):
        theta, phi = np.meshgrid((np.arange(m) + 0.5) / m * np.pi, (np.arange(2 * m) + 0.5) / m * np.pi, indexing="ij")
        dirs = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1).reshape(-1, 3)
        dw = (np.sin(theta) * (np.pi / m) ** 2).reshape(-1)
        v = np.array([np.sqrt(1 - mu * mu), 0.0, mu])          # N = z, T = x
        h = dirs + v
        n_dot_h = np.clip(h[:, 2] / np.linalg.norm(h, axis=-1), 0.0, 1.0)
        n_dot_l = dirs[:, 2]
        f = np.where(n_dot_l > 0, lobes.d_charlie(n_dot_h, r * r) * lobes.v_sheen(np.maximum(n_dot_l, 1e-9), mu, r * r)
                     * n_dot_l, 0.0) * dw
        return np.array([np.sum(f * n_dot_l), np.sum(f * dirs[:, 0])]) / np.sum(f)
    for mu, r in ((0.3, 0.25), (0.6, 0.5), (0.9, 1.0)):
        coarse, fine = brute(mu, r, 400), brute(mu, r, 800)
        quadrature = sheen_centroid(mu, r)
        bound = 4 / 3 * np.abs(coarse - fine) + np.abs(quadrature - sheen_centroid(mu, r, n=320))
        assert (np.abs(quadrature - coarse) <= bound).all(), (mu, r, quadrature, coarse, bound)


def sheen_centroid_read(n_dot_v, sheen_perceptual_roughness):
    """(c_n, c_t) as lobes_ibl.glsl's sheen_centroid reads shading.sheen's table: bilinear over
    sqrt(1 - N.V) and the roughness, in float64."""
    from sdfpbr.shading.sheen import SHEEN_CENTROID, SHEEN_CENTROID_STEPS
    rows, cols = SHEEN_CENTROID_STEPS
    table = np.array(SHEEN_CENTROID, np.float64)
    x = np.sqrt(np.clip(1.0 - np.asarray(n_dot_v, np.float64), 0.0, 1.0)) * (rows - 1)
    y = np.clip(np.asarray(sheen_perceptual_roughness, np.float64), 0.0, 1.0) * (cols - 1)
    i, j = np.minimum(x.astype(int), rows - 2), np.minimum(y.astype(int), cols - 2)
    fx, fy = (x - i)[..., None], (y - j)[..., None]
    near_r = (1 - fx) * table[i, j] + fx * table[i + 1, j]
    far_r = (1 - fx) * table[i, j + 1] + fx * table[i + 1, j + 1]
    return (1 - fy) * near_r + fy * far_r


class LinearSky:
    """L(d) = 1 + g . d, grey: SH bands 0 and 1 only. Under it any lobe p gathers exactly
    int p(l) L(l) dl = 1 + g . c, c the lobe's mean direction, which is what the chart's
    lean read of the sheen (shading.sheen, lobes_ibl.glsl) takes: exact here."""
    g = np.array([0.3, 0.8, -0.2])

    def radiance(self, d):
        return np.repeat((1.0 + np.asarray(d, np.float64) @ self.g)[..., None], 3, -1)

    to_equirect = ibl_oracle.LobeSky.to_equirect


def test_the_sheen_gathers_its_light_where_its_lobe_leans(session, tmp_path):
    """A sheen alone (black base, specular 0, sheen colour 1) under LinearSky, no floor or
    lights: each sphere pixel is int D_charlie V_sheen L(l) N.L dl, integrated here on a
    300 x 600 midpoint grid of the sphere. The chart must match it within what its parts
    allow, each computed here at the pixel: E_s as the chart reads it (its DFG table, read back
    and interpolated as dfg.glsl does) against the float64 E_s, on radiance up to 1 + |g|; the
    mean direction as the chart reads it (shading.sheen's table, interpolated as lobes_ibl.glsl
    does) against the float64 one, on a gradient |g|; the chart's SH9 of the map against the
    exact one, read along that direction; the midpoint sum's own error; float32 (1e-5).
    Read along N as a cosine lobe, the pixels would be E_s (1 + 2/3 g . N): the Charlie lobe
    leans to V and the horizon, so that misses most pixels by more."""
    from sdfpbr.gpu.ibl import make_environment
    from sdfpbr.shading.camera import frame_grid, sphere_centers
    from sdfpbr.shading.plan import chart_frame
    sky = LinearSky()
    path = tmp_path / "linear_sky.npy"
    np.save(path, sky.to_equirect(1024))
    roughness = (0.25, 0.5, 1.0)
    spec = make_spec(env=str(path), lights="none", ground=False, ao=False, shadows=False, stage="shared",
                     rows=1, cols=3, width=288, height=96, tonemap="none", base_color=(0.0, 0.0, 0.0), specular=0.0,
                     sheen_color=(1.0, 1.0, 1.0), x_axis="sheen_roughness", x_values=roughness, antialias=False)
    assert render_plan(spec).options["SHEEN_LEAN"]
    res = session.render(spec, aovs=True, hdr=True)
    aov = res.aov
    rng = np.random.default_rng(0)
    picked = []
    for col in range(3):
        ys, xs = np.nonzero((aov["col"] == col) & (aov["ndotv"] > 0.2) & (aov["ndotv"] < 0.95) & (aov["coverage"] == 1))
        k = rng.choice(ys.size, 30, replace=False)
        picked += [(col, y, x) for y, x in zip(ys[k], xs[k])]
    col, y, x = np.array(picked).T
    n = aov["normal"][y, x].astype(np.float64)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    v = frame_grid(spec).position - (sphere_centers(spec)[0, col] + spec.sphere_radius * n)
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    alpha = np.array(roughness)[col] ** 2
    got = res.hdr[y, x, 0].astype(np.float64)
    def sphere_grid(m):
        theta, phi = np.meshgrid((np.arange(m) + 0.5) / m * np.pi, (np.arange(2 * m) + 0.5) / m * np.pi, indexing="ij")
        dirs = np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)], -1).reshape(-1, 3)
        return dirs, (np.sin(theta) * (np.pi / m) ** 2).reshape(-1) * sky.radiance(dirs)[:, 0]

    def gathered(i, dirs, weight):
        n_dot_l = dirs @ n[i]
        h = dirs + v[i]
        n_dot_h = np.clip((h @ n[i]) / np.linalg.norm(h, axis=-1), 0.0, 1.0)
        f = np.where(n_dot_l > 0, lobes.d_charlie(n_dot_h, alpha[i])
                     * lobes.v_sheen(np.maximum(n_dot_l, 1e-9), n[i] @ v[i], alpha[i])
                     * n_dot_l, 0.0)
        return np.sum(f * weight)
    grids = sphere_grid(300), sphere_grid(150)
    truth, truth_step = np.empty(len(n)), np.empty(len(n))
    e_s, c_exact = np.empty(len(n)), np.empty((len(n), 2))
    for i in range(len(n)):
        truth[i] = gathered(i, *grids[0])
        # The midpoint sum's own error: the horizon's kink lies off its grid (n is not its
        # pole), so at least first order: its step from a grid half as fine bounds it.
        truth_step[i] = abs(truth[i] - gathered(i, *grids[1]))
        e_s[i] = lobes.sheen_albedo(n[i] @ v[i], np.sqrt(alpha[i]))
        c_exact[i] = sheen_centroid(n[i] @ v[i], np.sqrt(alpha[i]))
    n_dot_v, r = np.sum(n * v, -1), np.sqrt(alpha)
    table = chart_dfg_table(session, spec)
    e_s_read_error = dfg_read_error(table, n_dot_v, r, e_s, 3)   # 8-bit filter fractions included
    c_read = sheen_centroid_read(n_dot_v, r)
    # The chart's SH9 of the map against the exact one of 1 + g . d (E = pi + 2 pi / 3 g . n),
    # read as lobes_ibl.glsl reads it: along the lobe's axis, bands 1 and 2 scaled.
    with session.ctx:
        sh = session.ibl.lighting(make_environment(session.ctx, chart_frame(spec)),
                                  render_plan(spec).ibl).sh.astype(np.float64)
    exact_sh = np.zeros((9, 3))
    exact_sh[0], exact_sh[1], exact_sh[2], exact_sh[3] = np.pi, *(2 * np.pi / 3 * sky.g[[1, 2, 0], None])
    t = v - n_dot_v[:, None] * n
    axis = c_read[:, :1] * n + c_read[:, 1:] * t / np.linalg.norm(t, axis=-1, keepdims=True)
    band1 = 1.5 * np.linalg.norm(axis, axis=-1)
    d = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    x, y, z = d.T
    basis = np.stack([np.ones_like(x), band1 * y, band1 * z, band1 * x, band1 ** 2 * x * y, band1 ** 2 * y * z,
                      band1 ** 2 * (3 * z * z - 1), band1 ** 2 * x * z, band1 ** 2 * (x * x - y * y)], -1)
    sh_error = np.abs(basis @ (sh - exact_sh)).max(-1) / np.pi
    g = np.linalg.norm(sky.g)
    bound = (e_s_read_error * (1.0 + g) + e_s * g * np.linalg.norm(c_read - c_exact, axis=-1)
             + (e_s + e_s_read_error) * sh_error + truth_step + 1e-5 * (1.0 + g))
    assert np.all(np.abs(got - truth) <= bound), np.max(np.abs(got - truth) / bound)
    along_n = e_s * (1.0 + (2.0 / 3.0) * (n @ sky.g))
    assert np.mean(np.abs(along_n - truth) > bound) > 0.5
