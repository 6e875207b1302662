"""The KHR lobes (clearcoat, sheen, specular/ior, emission) in the chart shader, the reference
and the float64 mirror (sdfpbr.oracle.lobes): GLSL against float64 per lobe, the reference's
furnace against the mirror's directional albedo, the chart's split-sum furnace against the
mirror, and a scene that does not use a lobe does not compile it."""
import shutil

import numpy as np
import pytest
from test_reference import FURNACE, check_converged, interior, luminance, primary_hits

from sdfpbr.gpu.programs import set_uniforms
from sdfpbr.oracle import lobes, mirror
from sdfpbr.shading.compose import shader_dir
from sdfpbr.shading.plan import compose_program, render_plan
from sdfpbr.spec.chart_spec import make_spec
from sdfpbr.spec.material import Material
from sdfpbr.tools.energy import furnace_spec
from sdfpbr.tools.reference import compensation_table, render_reference

# One material per lobe, each with the core material under it (a rough dielectric base, so
# the lobes' effect on the base is visible), and the spec keys that give it to a chart.
LOBE_MATERIALS = {
    "clearcoat": (Material(base_color=(0.8, 0.3, 0.2), roughness=0.6, clearcoat=1.0, clearcoat_roughness=0.25),
                  dict(base_color=(0.8, 0.3, 0.2), roughness=0.6, clearcoat=1.0, clearcoat_roughness=0.25)),
    "sheen": (Material(base_color=(0.3, 0.3, 0.6), roughness=0.5, sheen_color=(1.0, 0.6, 0.8), sheen_roughness=0.4),
              dict(base_color=(0.3, 0.3, 0.6), roughness=0.5, sheen_color=(1.0, 0.6, 0.8), sheen_roughness=0.4)),
    "specular": (Material(base_color=(0.2, 0.5, 0.2), roughness=0.4, ior=2.2, specular=0.7,
                          specular_color=(1.0, 0.6, 0.3)),
                 dict(base_color=(0.2, 0.5, 0.2), roughness=0.4, ior=2.2, specular=0.7, specular_color=(1.0, 0.6, 0.3))),
}
LOBE_OPTIONS = {"clearcoat": "CLEARCOAT", "sheen": "SHEEN", "specular": "KHR_SPECULAR"}

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


def _units(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("lobe", sorted(LOBE_MATERIALS))
def test_glsl_layers_match_the_float64_mirror(ctx, session, tmp_path, lobe):
    """brdf_cos with the lobe composed in, at 4096 random directions, against
    sdfpbr.oracle.lobes.layered_brdf. The sheen's albedo scaling reads E_s from a 128² float64
    table (the reference's) bilinearly: its error is below 1e-4, inside the tolerance of the
    core BRDF's own test (rtol 2e-3)."""
    m, _ = LOBE_MATERIALS[lobe]
    rng = np.random.default_rng(11)
    count = 4096
    n = _units(rng, count)
    v = _units(rng, count)
    v = np.where((v * n).sum(1, keepdims=True) < 0, -v, v)
    l = _units(rng, count)
    n_dot_v = np.clip((n * v).sum(1), mirror.MIN_N_DOT_V, 1)
    e = mirror.single_scatter_albedo(n_dot_v, np.full(count, max(m.roughness, mirror.MIN_PERCEPTUAL_ROUGHNESS)), "gltf")
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
    want = lobes.layered_brdf(n, v, l, m, e_spec=e) * np.clip((n * l).sum(1), 0, None)[:, None]
    assert np.isfinite(got).all()
    # E_s rises steeply towards N.V = 0 (0.14 to 0.71 below N.V = 0.5 at r = 0.4), where the
    # table's bilinear error passes 2e-3; the table itself is tested below (test_sheen_lut...).
    n_dot_l = (n * l).sum(1)
    away = (n_dot_v >= 0.05) & ((n_dot_l >= 0.05) | (n_dot_l <= 0.0)) if lobe == "sheen" else np.ones(count, bool)
    assert away.mean() > 0.8
    np.testing.assert_allclose(got[away], want[away], rtol=2e-3, atol=1e-5)
    assert (want > 0.3).any() and (want == 0).any()


@pytest.mark.parametrize("lobe", sorted(LOBE_MATERIALS))
def test_reference_furnace_matches_the_mirror_per_lobe(session, lobe):
    """Under the uniform environment with one bounce, each pixel of the reference integrates
    f cos over the hemisphere: the float64 directional albedo of the layered material."""
    m, keys = LOBE_MATERIALS[lobe]
    spec = make_spec(**{**FURNACE, **keys, "metallic": 0.0, "antialias": False})
    res = render_reference(spec, samples=256, max_bounces=1, seed=5, session=session)
    hits = primary_hits(spec)
    mask = interior(spec, hits, 0.15)
    assert mask.sum() > 500 and res.non_finite == 0
    grid = np.linspace(0.0, 1.0, 257)
    albedo = lobes.layered_albedo(grid, m)
    ndotv = (hits[3] * hits[4]).sum(-1)
    want = np.stack([np.interp(ndotv, grid, albedo[:, c]).mean(-1) for c in range(3)], -1)
    check_converged(luminance(res.hdr)[mask], luminance(want)[mask], res.stderr[mask])


@pytest.mark.parametrize("lobe", sorted(LOBE_MATERIALS))
def test_chart_furnace_matches_the_mirror_per_lobe(session, lobe):
    """The chart's split sum with the layers (lobes_ibl.glsl) under the white furnace: exact
    there but for the LUTs, so within the core material's own bound (1 % at N.V >= 0.2,
    tests/test_energy.py), against the mirror's albedo with the sheen scaled as the chart's
    environment light scales it (the spec's simplified form, N.V only)."""
    m, keys = LOBE_MATERIALS[lobe]
    spec = furnace_spec(make_spec(**keys, width=96, height=96, rows=1, cols=1, metallic=0.0), white=False)
    res = session.render(spec)
    aov = res.aov
    mask = (aov["row"] == 0) & (aov["ndotv"] >= 0.2)
    assert mask.sum() > 1000
    grid = np.linspace(0.0, 1.0, 257)
    albedo = lobes.layered_albedo(grid, m, sheen_scaling="view")
    want = np.stack([np.interp(aov["ndotv"][mask], grid, albedo[:, c]) for c in range(3)], -1)
    got = res.hdr[mask][:, :3].astype(np.float64)
    assert np.abs(got - want).max() < 1e-2 * max(1.0, want.max())
    core = lobes.layered_albedo(grid, Material(base_color=m.base_color, roughness=m.roughness))
    assert np.abs(albedo - core).max() > 0.05   # the lobe changes the albedo by far more than the bound


def test_sheen_lut_matches_float64(session):
    """The chart's DFG bake with SHEEN: its alpha channel is the sheen's albedo E_s."""
    plan = render_plan(make_spec(sheen_color=(1.0, 1.0, 1.0)))
    assert "SHEEN" in dict(plan.dfg.options)
    with session.ctx:
        table = session.ibl.compute_dfg_table(plan.dfg, 32, plan.dfg_samples)
    grid = np.arange(32) / 31
    want = lobes.sheen_albedo(np.maximum(grid[None, :], mirror.MIN_N_DOT_V), grid[:, None])
    # The core LUT's bound (tests/test_shading.py), grazing angles and the smallest roughness
    # (E_s up to 1.8 there: the clamped Charlie visibility is not bounded by 1) included.
    assert np.abs(table[..., 3] - want).max() < 5e-3


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


def test_a_scene_compiles_only_the_lobes_it_uses():
    default = render_plan(make_spec()).chart
    assert not {"CLEARCOAT", "SHEEN", "KHR_SPECULAR", "EMISSION"} & set(dict(default.options))
    assert "d_charlie" not in default.text and "clearcoat_layer" not in default.text
    coat = render_plan(make_spec(clearcoat=0.5)).chart
    assert dict(coat.options).get("CLEARCOAT") and "clearcoat_layer" in coat.text and "d_charlie" not in coat.text
    # Values that change nothing switch nothing on: ior 1.5 with specular 1 is the core f0.
    assert not dict(render_plan(make_spec(ior=1.5, specular=1.0, clearcoat=0.0)).chart.options).get("KHR_SPECULAR")
