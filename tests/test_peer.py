"""The bench's peer (sdfpbr.devtools.bench.peer): Mitsuba 3 rendering the bench's scenes with a
glTF BSDF written from the specification. Its parts are checked against numbers of their own
(the float64 BRDF model, Mitsuba's chi^2 test, the chart's AOVs, closed forms), then sdfpbr's
reference against it on tiny scenes: every region within their combined noise (two seeds each).
The tests that render with Mitsuba skip, with the reason, where the 'peer' extra or its LLVM
runtime is missing."""
import math
import subprocess
import sys

import numpy as np
import pytest

from sdfpbr.devtools.bench import peer, peer_bsdf, peer_scene
from sdfpbr.devtools.bench.suite import scene_overrides
from sdfpbr.features.reference import render_reference
from sdfpbr.oracle import shading_model
from sdfpbr.spec.chart_spec import Light, make_spec
from sdfpbr.spec.material import Material


@pytest.fixture(scope="module")
def mi():
    problem = peer.peer_problem()
    if problem:
        pytest.skip(f"needs the peer: {problem}")
    return peer.load_mitsuba()


def gl_bilinear(data: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """A GL_LINEAR lookup of an (H, W, 3) map at (u, v), u repeating and v clamped to the edge
    rows: how sdfpbr's env.glsl reads a map file."""
    h, w = data.shape[:2]
    x, y = u * w - 0.5, v * h - 0.5
    i0, j0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - i0)[..., None], (y - j0)[..., None]
    i0, i1 = i0 % w, (i0 + 1) % w
    j0, j1 = np.clip(j0, 0, h - 1), np.clip(j0 + 1, 0, h - 1)
    top = data[j0, i0] * (1 - fx) + data[j0, i1] * fx
    bottom = data[j1, i0] * (1 - fx) + data[j1, i1] * fx
    return top * (1 - fy) + bottom * fy


def lopsided_map(width: int = 48, height: int = 24) -> np.ndarray:
    """A map no turn or mirror leaves alike: colour ramps along u and v, a bright spot off
    every axis."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    uu, vv = np.meshgrid(u, v)
    spot = 3.0 * np.exp(-((uu - 0.3) ** 2 + (vv - 0.35) ** 2) / 0.02)
    return np.stack([0.2 + 0.6 * uu + spot, 0.3 + 0.5 * (1 - vv),
                     0.1 + 0.4 * uu * vv + 0.5 * spot], -1).astype(np.float32)


# ---- without Mitsuba ---------------------------------------------------------------------

def test_scenes_with_lobes_the_peer_lacks_are_not_comparable():
    why = peer_scene.not_comparable(make_spec(**scene_overrides("lobes")))
    assert "clearcoat" in why and "sheen" in why
    assert peer_scene.not_comparable(make_spec(**scene_overrides("default"))) is None
    assert peer_scene.not_comparable(make_spec(ior=1.8)) is None   # KHR_materials_ior: the peer has it
    point = Light("point", position=(3.0, 4.0, 2.0), intensity=5.0, radius=0.2)
    assert "radius" in peer_scene.not_comparable(make_spec(lights=(point,)))


def test_equal_error_follows_a_power_law_between_and_past_its_rungs():
    # e = 0.1 / sqrt(n), t = 0.01 n: e = 0.1 / sqrt(10) takes n = 10, t = 0.1.
    curve = [{"samples": n, "seconds": 0.01 * n, "flip_mean": 0.1 / math.sqrt(n)} for n in (1, 4, 16, 64)]
    inside = peer.equal_error(0.1 / math.sqrt(10), curve)
    assert inside["samples"] == pytest.approx(10.0) and inside["seconds"] == pytest.approx(0.1)
    past = peer.equal_error(0.1 / math.sqrt(256), curve)
    assert past["extrapolated"] and past["samples"] == pytest.approx(256.0)
    first = peer.equal_error(0.5, curve)
    assert first["at_most"] and first["samples"] == 1
    assert peer.ladder(64) == [1, 4, 16, 64] and peer.ladder(100) == [1, 4, 16, 64, 100]


def test_a_map_file_becomes_the_envmap_of_the_same_bilinear_surface():
    data = lopsided_map()
    h = data.shape[0]
    out = peer_scene.file_envmap(data)
    u, v = peer_scene.envmap_knots(data.shape[1], 2 * h + 1)
    np.testing.assert_allclose(out, gl_bilinear(data, u, v), rtol=1e-6, atol=1e-7)


def test_the_peer_without_its_extra_is_one_line_naming_the_install(tmp_path):
    from helpers import blocked

    from sdfpbr.extras import install_command
    r = subprocess.run([sys.executable, "-m", "sdfpbr", "bench", "--peer", "mitsuba", "--quick", "--no-cold"],
                       check=False, capture_output=True, text=True, cwd=tmp_path, env=blocked(tmp_path, "mitsuba"),
                       timeout=300)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and install_command("peer") in lines[0], r.stderr


def test_an_unknown_peer_is_one_line():
    bad = subprocess.run([sys.executable, "-m", "sdfpbr", "bench", "--peer", "blender", "--quick"],
                         check=False, capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "allowed: mitsuba" in bad.stderr


# ---- the peer's parts ----------------------------------------------------------------------

def test_envmap_knots_are_where_the_conversion_puts_them(mi):
    """One lit texel of a Mitsuba envmap turned by FLIP_U reads 1 at the direction
    envmap_knots and lat_long_direction give it, 1/2 half-way to the next knot, 0 at it."""
    import drjit as dr
    w, h, i, j = 8, 5, 2, 1
    data = np.zeros((h, w, 3), np.float32)
    data[j, i] = 1.0
    envmap = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(data),
                           "to_world": mi.ScalarTransform4f([list(r) for r in peer_scene.FLIP_U])})
    u, v = peer_scene.envmap_knots(w, h)
    at = [(u[j, i], v[j, i]), (0.5 * (u[j, i] + u[j, i + 1]), v[j, i]), (u[j, i], 0.5 * (v[j, i] + v[j + 1, i])),
          (u[j, i + 1], v[j, i]), (u[j, i], v[j + 1, i])]
    d = peer_scene.lat_long_direction(*np.array(at).T)
    si = dr.zeros(mi.SurfaceInteraction3f, len(at))
    si.wi = mi.Vector3f(*(-d.T).astype(np.float32))
    got = np.asarray(envmap.eval(si))[0]
    np.testing.assert_allclose(got, [1.0, 0.5, 0.5, 0.0, 0.0], atol=1e-5)


def test_a_map_file_reads_in_mitsuba_as_sdfpbr_reads_it(mi):
    import drjit as dr
    data = lopsided_map()
    rng = np.random.default_rng(5)
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    u = np.arctan2(d[:, 0], -d[:, 2]) / (2 * np.pi) + 0.5      # env.glsl's lookup
    v = np.arccos(np.clip(d[:, 1], -1, 1)) / np.pi
    expected = gl_bilinear(data, u, v)

    def read(to_world):
        envmap = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(peer_scene.file_envmap(data)),
                               "to_world": mi.ScalarTransform4f([list(r) for r in to_world])})
        si = dr.zeros(mi.SurfaceInteraction3f, len(d))
        si.wi = mi.Vector3f(*(-d.T).astype(np.float32))
        return np.asarray(envmap.eval(si)).T

    # float32 directions and weights: a part in 1e5 of the map's range.
    np.testing.assert_allclose(read(peer_scene.FLIP_U), expected, atol=1e-5 * data.max())
    unturned = np.eye(4).tolist()
    assert np.abs(read(unturned) - expected).max() > 0.1 * data.max()


def test_bsdf_is_the_float64_model_pointwise(mi):
    """f cos of the plugin against the oracle's glTF BRDF, compensation on, at random
    directions and materials. float32 evaluation: some 50 roundings of 6e-8, conditioned up
    to ~1e2 at the smoothest lobes' peaks and at grazing angles: 1e-3 relative."""
    import drjit as dr
    rng = np.random.default_rng(3)
    cls = peer_bsdf.plugin_class()
    n = 2000
    for base, metallic, roughness, ior in (((0.8, 0.3, 0.08), 0.0, 0.5, 1.5), ((0.95, 0.64, 0.54), 1.0, 0.045, 1.5),
                                           ((0.2, 0.5, 0.9), 0.4, 0.9, 1.5), ((0.5, 0.5, 0.5), 0.0, 0.25, 2.0)):
        props = mi.Properties()
        props["multiscatter"] = True
        bsdf = cls(props)
        material = Material(base_color=base, metallic=metallic, roughness=roughness, ior=ior)
        bsdf.set(material)
        wi, wo = (rng.normal(size=(n, 3)) for _ in range(2))
        for w in (wi, wo):
            w /= np.linalg.norm(w, axis=1, keepdims=True)
            w[:, 2] = np.abs(w[:, 2])
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        si.wi = mi.Vector3f(*wi.T.astype(np.float32))
        got = np.asarray(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*wo.T.astype(np.float32)))).T
        f0 = ((ior - 1) / (ior + 1)) ** 2
        expected = _oracle_f_cos(wi, wo, material, f0)
        np.testing.assert_allclose(got, expected, rtol=1e-3, atol=1e-6 * expected.max())


def _oracle_f_cos(wi, wo, m: Material, f0: float) -> np.ndarray:
    """The glTF BRDF times N.L from the float64 model; its dielectric f0 is 0.04, so another
    f0 (KHR_materials_ior) is taken in the specification's form, from the model's terms."""
    normal = np.array([0.0, 0.0, 1.0])
    if abs(f0 - shading_model.DIELECTRIC_F0) < 1e-12:
        return shading_model.brdf(normal, wi, wo, m.base_color, m.metallic, m.roughness, multiscatter=True) * wo[:, 2:3]
    r = max(m.roughness, shading_model.MIN_PERCEPTUAL_ROUGHNESS)
    alpha = r * r
    n_dot_v = np.clip(wi[:, 2], shading_model.MIN_N_DOT_V, 1.0)
    h = shading_model.normalize(wi + wo)
    v_dot_h = np.abs(np.sum(wi * h, -1))
    spec = shading_model.d_ggx(h[:, 2], alpha) * shading_model.vis_smith_ggx_correlated(wo[:, 2], n_dot_v, alpha)
    e = shading_model.single_scatter_albedo(n_dot_v, np.full_like(n_dot_v, r), "gltf")
    fresnel = f0 + (1 - f0) * shading_model.fresnel_weight(v_dot_h)
    base = np.asarray(m.base_color)
    dielectric = base / np.pi * (1 - fresnel)[:, None] + (spec * fresnel * (1 + f0 * (1 / e - 1)))[:, None]
    metal = spec[:, None] * shading_model.fresnel_schlick(base, v_dot_h) * shading_model.energy_compensation(base, e)
    return ((1 - m.metallic) * dielectric + m.metallic * metal) * wo[:, 2:3]


@pytest.mark.parametrize("multiscatter", [False, True])
def test_bsdf_albedo_by_its_own_sampling_is_the_models(mi, multiscatter):
    """The mean of the plugin's sample weights (f cos / pdf) is the directional albedo,
    which the float64 model gives by quadrature (furnace_expected): within 5 standard errors
    of the 2^20-sample mean (its own spread)."""
    import drjit as dr
    cls = peer_bsdf.plugin_class()
    count = 1 << 20
    for mu, material in ((0.05, Material(base_color=(0.8, 0.3, 0.08), metallic=0.5, roughness=0.3)),
                         (0.6, Material(base_color=(0.95, 0.64, 0.54), metallic=1.0, roughness=0.045)),
                         (0.9, Material(base_color=(0.2, 0.5, 0.9), metallic=0.0, roughness=1.0))):
        props = mi.Properties()
        props["multiscatter"] = multiscatter
        bsdf = cls(props)
        bsdf.set(material)
        si = dr.zeros(mi.SurfaceInteraction3f, count)
        si.wi = mi.Vector3f(math.sqrt(1 - mu * mu), 0.0, mu)
        rng = mi.PCG32(count)
        _, weight = bsdf.sample(mi.BSDFContext(), si, rng.next_float32(),
                                mi.Point2f(rng.next_float32(), rng.next_float32()))
        weight = np.asarray(weight, np.float64)
        mean, stderr = weight.mean(axis=1), weight.std(axis=1) / math.sqrt(count)
        expected = shading_model.furnace_expected(mu, material.base_color, material.metallic, material.roughness,
                                                  multiscatter=multiscatter)
        assert np.all(np.abs(mean - expected) <= 5 * stderr + 1e-6), (mu, material, mean, expected, stderr)


def test_bsdf_sampling_passes_mitsubas_chi2(mi):
    """Mitsuba's own chi^2 test of the sampled directions against the pdf (lobes wide enough
    for its cell quadrature of the pdf: alpha >= 0.09)."""
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain
    peer_bsdf.plugin_class()
    for roughness, metallic, mu in ((0.3, 0.5, 0.7), (1.0, 1.0, 0.9), (0.5, 0.0, 0.2)):
        props = {"type": peer_bsdf.PLUGIN, "roughness": roughness, "metallic": metallic,
                 "base_color": mi.ScalarColor3f(0.8, 0.3, 0.08)}
        sample, pdf = BSDFAdapter(peer_bsdf.PLUGIN, props, wi=[math.sqrt(1 - mu * mu), 0.0, mu])
        test = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf, sample_dim=3)
        assert test.run(), (roughness, metallic, mu, test.messages)


@pytest.mark.parametrize("stage", ["cells", "shared"])
def test_the_peers_camera_and_geometry_are_the_charts(mi, session, stage):
    spec = make_spec(rows=2, cols=2, width=70, height=64, cell_borders=False, stage=stage)
    check = peer.geometry_check(spec, session)
    assert check["ok"] and check["pixels"] > 500, check


# ---- the reference against the peer -------------------------------------------------------

def _validate(spec, samples, session, **options):
    refs = [render_reference(spec, samples=samples, seed=seed, session=session).hdr for seed in (0, 1)]
    peer_session = peer.PeerSession(spec, 4, options)
    peers = [peer_session.render(samples, seed).hdr for seed in (0, 1)]
    return peer.region_stats(peer.region_masks(spec), *refs, *peers)


def test_a_mirror_sphere_shows_the_environment_as_the_reference_does(mi, session, tmp_path):
    """A near-mirror sphere, no floor, under a lopsided map file: every direction of the map
    reflected. Turned as peer_scene derives it, the peer agrees with the reference within
    noise, region by region and pixel by pixel; left in Mitsuba's own orientation (half a turn
    off), it does not. The background, camera rays reading the map with no noise but their
    pixel's area, shows how GL filters the reference's map (llvmpipe's GL_LINEAR weights carry
    8 bits): a bias under 1/512 of the map's largest step between texels, which is held."""
    data = lopsided_map()
    path = tmp_path / "lopsided.npy"
    np.save(path, data)
    spec = make_spec(rows=1, cols=1, width=32, height=32, cell_borders=False, ground=False, lights="none",
                     metallic=(1.0, 1.0), roughness=(0.0, 0.0), base_color=(1.0, 1.0, 1.0), env=str(path))
    regions = _validate(spec, 64, session)
    background = regions.pop("background")
    assert set(regions) == {"sphere_upper", "sphere_lower", "silhouette"}
    assert all(r["within"] for r in regions.values()), regions
    # Pixel by pixel, noise alone: the ratio's spread is some sqrt(3 / pixels) (sums of
    # squared normals, two seeds a side), under 0.25 on >= 48 pixels; 2 is far out of it.
    assert all(r["pixel_ratio"] < 2.0 for r in regions.values()), regions
    lum = data @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    step = max(np.abs(np.diff(lum, axis=0)).max(), np.abs(np.diff(lum, axis=1)).max())
    assert abs(background["reference"] - background["peer"]) <= step / 512, background
    wrong = _validate(spec, 16, session, envmap_to_world=np.eye(4).tolist())
    assert min(r["pixel_ratio"] for r in wrong.values()) > 10.0, wrong


def test_the_reference_is_within_the_peers_noise_on_a_tiny_scene(mi, session):
    """The bench's default scene, one 32 x 32 cell, 256 samples a pixel and two seeds of
    each renderer: the sphere's halves and silhouette, the floor under it, round it and far
    from it agree within NOISE_SIGMAS of their combined noise."""
    spec = make_spec(**{**scene_overrides("default"), "rows": 1, "cols": 1, "width": 32, "height": 32})
    regions = _validate(spec, 256, session)
    assert set(regions) == {"sphere_upper", "sphere_lower", "silhouette", "floor_bulge", "floor_ring", "floor_far"}
    assert all(r["within"] for r in regions.values()), regions
