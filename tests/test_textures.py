"""Textured spheres: colour spaces and conventions checked against untextured renders whose
factors are the decoded texel values (sRGB curve for base colour, identity for ORM)."""
import imageio.v3 as iio
import numpy as np
import pytest
from helpers import PROGRAM_RTOL

from sdfpbr.errors import SpecError
from sdfpbr.oracle.display import srgb_eotf
from sdfpbr.spec.chart_spec import ChartSpec, make_spec
from sdfpbr.gpu.textures import PROCEDURAL_SETS, hammered_set, procedural_set, texture_set
from sdfpbr.spec.presets import PROCEDURAL_MAPS



def srgb_decode_window(codes):
    """(low, high): the linear values a driver's sRGB decode of 8-bit codes may give. GL leaves
    the decode's precision to the driver (llvmpipe fits a polynomial); a decode must keep each
    code nearer its own value on the curve than either neighbour's, so halfway to each."""
    c = np.asarray(codes, np.float64)
    own = srgb_eotf(c / 255.0)
    below, above = srgb_eotf(np.maximum(c - 1.0, 0.0) / 255.0), srgb_eotf(np.minimum(c + 1.0, 255.0) / 255.0)
    return 0.5 * (own + below), 0.5 * (own + above)


def assert_between_renders(session, spec, got, mask, low, high):
    """The pixels ``got`` lie between renders of ``spec`` with base colour ``low`` and ``high``
    (a pixel grows with its base colour, dielectric or metal), float32 aside."""
    lo, hi = (session.render(make_spec(spec, base_color=tuple(map(float, c)))).hdr[mask] for c in (low, high))
    slack = 1e-5 * np.abs(hi)
    assert ((got[mask] >= lo - slack) & (got[mask] <= hi + slack)).all()

FURNACE = ChartSpec(width=96, height=96, rows=2, cols=2, env="uniform", lights="none", ground=False,
                    labels=False, roughness=(0.5, 0.5), metallic=(0.0, 1.0), base_color=(1.0, 1.0, 1.0))


def _png(path, rgb):
    img = np.zeros((8, 16, 4), np.uint8)
    img[..., :3] = rgb
    img[..., 3] = 255
    iio.imwrite(path, img)
    return str(path)


def _interior(result):
    # Sphere pixels away from the rims, where texture filtering at the poles and seam is moot.
    return (result.aov["row"] >= 0) & (result.aov["ndotv"] > 0.5)


def test_base_color_map_is_decoded_as_srgb(session, tmp_path):
    flat_normal = _png(tmp_path / "n.png", (128, 128, 255))
    white_orm = _png(tmp_path / "orm.png", (255, 255, 255))
    textured = make_spec(FURNACE, base_color_texture=_png(tmp_path / "c.png", (128, 128, 128)),
                         orm_texture=white_orm, normal_texture=flat_normal)
    # Same maps except base colour: white texels, the decoded value as the factor instead --
    # each end of the window the driver's decode of 128 may take (gamma 2.2 is outside it).
    plain = make_spec(textured, base_color_texture=_png(tmp_path / "w.png", (255, 255, 255)))
    a = session.render(textured)
    assert_between_renders(session, plain, a.hdr, _interior(a), *(np.full(3, w) for w in srgb_decode_window(128)))


def test_orm_map_is_linear_and_scales_the_factors(session, tmp_path):
    flat_normal = _png(tmp_path / "n.png", (128, 128, 255))
    orm = _png(tmp_path / "orm.png", (255, 128, 191))
    textured = make_spec(FURNACE, orm_texture=orm, normal_texture=flat_normal,
                         base_color_texture=_png(tmp_path / "c.png", (255, 255, 255)))
    # Direct light, not the furnace: with energy compensation a white furnace hides roughness.
    textured = make_spec(textured, env="black", lights="default")
    # Same maps except ORM: white texels, the linear texel values folded into the factors.
    plain = make_spec(textured, roughness=(0.5 * 128 / 255,) * 2, metallic=(0.0, 191 / 255),
                      orm_texture=_png(tmp_path / "w.png", (255, 255, 255)))
    a, b = session.render(textured), session.render(plain)
    m = _interior(a)
    # The same factors but for a float32 ulp of each product (texel x factor in the shader,
    # here in Python): another order of roundings (test_bugs.PROGRAM_RTOL).
    np.testing.assert_allclose(a.hdr[m], b.hdr[m], rtol=PROGRAM_RTOL, atol=PROGRAM_RTOL * b.hdr[m].max())
    # The orm-srgb bug decodes 128 as 0.216: a glossier result, measurably different.
    c = session.render(make_spec(textured, bugs=("orm-srgb",)))
    assert np.abs(c.hdr[m] - b.hdr[m]).max() > 0.1


def test_normal_map_tilts_toward_plus_y_up(session, tmp_path):
    # A map tilted towards +Y (green 200) must make the spheres face up: under a sky-only light
    # (uniform upper hemisphere is approximated by a key light from straight above) they get
    # brighter than with the flat map; the green-flip bug makes them darker.
    up = _png(tmp_path / "up.png", (128, 200, 230))
    flat = _png(tmp_path / "flat.png", (128, 128, 255))
    top_lit = ChartSpec(width=96, height=96, rows=1, cols=1, env="black", ground=False, labels=False,
                        ibl=False, metallic=(0.0, 0.0), roughness=(1.0, 1.0), base_color=(1.0, 1.0, 1.0),
                        lights=[{"kind": "directional", "direction": (0.0, 1.0, 0.0), "intensity": 1.0,
                                 "angular_radius_deg": 0.5}])
    white = _png(tmp_path / "w.png", (255, 255, 255))
    specs = {name: make_spec(top_lit, normal_texture=path, orm_texture=white, base_color_texture=white)
             for name, path in (("up", up), ("flat", flat))}
    r_up, r_flat = session.render(specs["up"]), session.render(specs["flat"])
    r_flip = session.render(make_spec(specs["up"], bugs=("normal-map-green-flip",)))
    m = _interior(r_flat) & (r_flat.aov["normal"][..., 1] < 0.5)   # the front, not the lit cap
    def lum(r):
        return r.hdr[m].mean()
    assert lum(r_up) > 1.2 * lum(r_flat) > 1.2 * lum(r_flip)


# A unit normal stored in 8-bit codes: each component within half a code of [0, 1], a code
# of [-1, 1]; the vector within sqrt(3) codes, and so its length.
NORMAL_CODE_ERROR = np.sqrt(3) / 255


def test_procedural_maps_are_valid():
    maps = procedural_set()
    n = maps.images["normal"][..., :3] / 255.0 * 2 - 1
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0, rtol=0, atol=NORMAL_CODE_ERROR)
    assert (n[..., 2] > 0).all()
    orm = maps.images["orm"][..., :3] / 255.0
    assert 0.3 < orm[..., 1].min() and orm[..., 1].max() == 1.0


@pytest.mark.parametrize("mode", list(PROCEDURAL_MAPS))
def test_each_procedural_mode_bakes_and_composes_its_own_maps(mode):
    from sdfpbr.shading.plan import render_plan
    spec = make_spec(FURNACE, textures=mode)
    assert set(texture_set(spec).images) == set(PROCEDURAL_MAPS[mode]) and mode in PROCEDURAL_SETS
    text = render_plan(spec).chart.text
    for name, sampler in (("base", "u_base_color_map"), ("orm", "u_orm_map"), ("normal", "u_normal_map")):
        assert (sampler in text) == (name in PROCEDURAL_MAPS[mode]), (mode, name)


@pytest.mark.parametrize("mode", list(PROCEDURAL_MAPS))
def test_a_procedural_set_is_kept_in_the_cache_and_read_back_unchanged(mode, tmp_path, monkeypatch):
    """Made once and written to the session's cache; a new process (here: the process's own
    copy forgotten) reads the same texels back instead of making them again."""
    from sdfpbr.cache import ArrayCache
    from sdfpbr.gpu import textures
    made = PROCEDURAL_SETS[mode]().images
    cache = ArrayCache(tmp_path)
    monkeypatch.setattr(textures, "_made", {})
    first = textures.procedural_maps(mode, cache)
    assert [p.parent.name for p in tmp_path.rglob("*.npz")] == ["textures"]
    monkeypatch.setattr(textures, "_made", {})
    monkeypatch.setattr(textures, "PROCEDURAL_SETS", {})   # reading back needs no generator
    again = textures.procedural_maps(mode, cache)
    assert again is not first and set(again.images) == set(made)
    for name in made:
        np.testing.assert_array_equal(again.images[name], made[name])
        np.testing.assert_array_equal(first.images[name], made[name])


def test_hammered_normals_are_unit_and_steep():
    """Unit, outward, and steep at the ridges between dimples (its docstring's 60 degrees and
    more), as the unclamped-N.V bug's scene needs."""
    n = hammered_set().images["normal"][..., :3] / 255.0 * 2 - 1
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0, rtol=0, atol=NORMAL_CODE_ERROR)
    tilt = np.degrees(np.arccos(np.clip(n[..., 2], -1, 1)))
    assert tilt.min() < 5 and tilt.max() > 60 and (tilt > 45).mean() > 0.05


def test_hammered_metal_bends_only_normals(session):
    """The hammered set is a normal map alone: in a uniform white furnace the split sum gives a
    white metal all of the sky whatever its normal (single scattering plus the multiple-
    scattering compensation sum to 1 for F0 = 1), and the horizon occlusion only takes away
    where a bent normal turns the reflection below the sphere's surface: the textured metal is
    nowhere brighter than the untextured one (to float rounding), and equal to it on most of
    the sphere; the dielectric, whose albedo depends on N.V, changes (the normals are bent)."""
    a, b = session.render(make_spec(FURNACE, textures="hammered")), session.render(FURNACE)
    metal = (a.aov["row"] == 1) & (b.aov["row"] == 1)
    dielectric = (a.aov["row"] == 0) & (b.aov["row"] == 0)
    ratio = a.hdr[metal][:, :3] / b.hdr[metal][:, :3]
    assert ratio.max() <= 1 + 1e-5
    assert (np.abs(ratio - 1) <= 1e-5).all(-1).mean() > 0.5
    assert np.abs(a.hdr[dielectric][:, :3] / b.hdr[dielectric][:, :3] - 1).max() > 0.05


def test_texture_paths_are_validated(tmp_path):
    with pytest.raises(SpecError, match="orm_texture"):
        make_spec(FURNACE, orm_texture=str(tmp_path / "missing.png"))
    with pytest.raises(SpecError, match="textures"):
        make_spec(FURNACE, textures="bumpy")


def test_a_base_color_texture_alone_adds_no_other_map(session, tmp_path):
    """Issue 10: a base-colour PNG alone is that map and nothing else: no procedural ORM or
    normal map is composed in, so the spheres equal untextured ones whose base colour is the
    decoded texel times the factor (the texture is one flat colour)."""
    from sdfpbr.shading.plan import render_plan
    # Point-sampled both: a textured small sphere takes one point a pixel, an untextured one
    # averages points of the pixel's box (plan.sphere_samples).
    spec = make_spec(FURNACE, base_color_texture=_png(tmp_path / "c.png", (200, 100, 50)), antialias=False)
    text = render_plan(spec).chart.text
    assert "u_base_color_map" in text and "u_orm_map" not in text and "u_normal_map" not in text
    a = session.render(spec)
    assert_between_renders(session, make_spec(FURNACE, antialias=False), a.hdr, _interior(a),
                           *srgb_decode_window([200, 100, 50]))


@pytest.mark.parametrize("shape, what", [((8, 16, 2), "grey+alpha"), ((8, 16), "grey")])
def test_grey_textures_are_read(session, tmp_path, shape, what):
    img = np.full(shape, 128, np.uint8)
    path = tmp_path / f"{what}.png"
    iio.imwrite(path, img)
    grey = make_spec(FURNACE, base_color_texture=str(path))
    rgb = make_spec(FURNACE, base_color_texture=_png(tmp_path / "rgb.png", (128, 128, 128)))
    np.testing.assert_array_equal(session.render(grey).hdr, session.render(rgb).hdr)


def test_unusable_textures_are_refused_with_one_line(session, tmp_path):
    frames = np.zeros((3, 8, 16, 4), np.uint8)
    iio.imwrite(tmp_path / "anim.png", frames)   # an animated PNG
    with pytest.raises(SpecError, match="one still image"):
        session.render(make_spec(FURNACE, base_color_texture=str(tmp_path / "anim.png")))
    limit = int(session.ctx.info["GL_MAX_TEXTURE_SIZE"])
    wide = np.zeros((2, limit + 1, 3), np.uint8)
    iio.imwrite(tmp_path / "wide.png", wide)   # GL would leave it undefined: a black sphere
    with pytest.raises(SpecError, match="at most"):
        session.render(make_spec(FURNACE, orm_texture=str(tmp_path / "wide.png")))


def test_mapped_normals_lose_the_sky_their_reflection_turns_below_the_sphere(session):
    """A white mirror metal (F = 1) under a uniform sky with the hammered normal map, no floor:
    the split sum alone gives exactly the sky's radiance L at every normal (the furnace); where
    a dimple turns the mirror direction below the sphere's own surface the reference blocks
    that light (reference_path.glsl). The chart's horizon occlusion fades the specular there
    ((1 + r . n_geo)^2, between nothing and the reference's step), so the sphere's mean lies
    between the reference's and L: strictly below L (it was exactly L without the fade), and
    not below the reference (beyond 4 of its standard errors)."""
    from sdfpbr.features.reference import render_reference
    spec = make_spec(rows=1, cols=1, width=96, height=96, labels=False, textures="hammered", roughness=0.0,
                     metallic=1.0, base_color=(1.0, 1.0, 1.0), env="uniform", lights="none", ground=False)
    sky = spec.env_intensity
    ref = render_reference(spec, samples=256, seed=2, session=session)
    chart = session.render(spec)
    sphere = chart.aov["coverage"] == 1
    def lum(h):
        return h[..., :3].astype(np.float64).mean(-1)
    ref_mean = lum(ref.hdr)[sphere].mean()
    se = np.sqrt((ref.stderr.astype(np.float64)[sphere] ** 2).sum()) / sphere.sum()
    chart_mean = lum(chart.hdr)[sphere].mean()
    assert ref_mean < 0.9 * sky, ref_mean / sky   # the map turns a good share below the surface
    assert ref_mean - 4 * se <= chart_mean < 0.99 * sky, (chart_mean / sky, ref_mean / sky)


def test_textured_spheres_compose_with_the_few_tap_ibl_bug(session):
    """The horizon occlusion splits the split sum's IBL into diffuse and specular; the few-tap
    bug's IBL has no such split, so it goes without (this pair once failed to compile)."""
    spec = make_spec(rows=1, cols=2, width=64, height=32, labels=False, textures="hammered", bugs=("fewtap-ibl",))
    hdr = session.render(spec).hdr
    assert np.isfinite(hdr).all() and hdr[..., :3].max() > 0


@pytest.mark.parametrize("mode", list(PROCEDURAL_MAPS))
def test_a_shared_set_is_uploaded_once_per_context_and_draws_as_uploaded_anew(session, mode, tmp_path):
    """A procedural set's GL textures are kept on the context (the gallery's textured pages
    render it again and again): a second render reuses them and draws what a render with a
    fresh upload draws; a set of the spec's own PNGs is uploaded for its render alone."""
    from sdfpbr.gpu.textures import KEPT_UPLOADS
    spec = make_spec(FURNACE, textures=mode, labels=False)
    kept = session.ctx.extra.setdefault("uploaded_maps", {})
    for entry in kept.values():
        for tex in entry[1].values():
            tex.release()
    kept.clear()
    first = session.render(spec).image
    (maps, textures), = kept.values()
    assert maps is texture_set(spec) and maps.shared
    second = session.render(spec).image
    assert len(kept) == 1 and all(a is b for a, b in zip(next(iter(kept.values()))[1].values(), textures.values()))
    for tex in textures.values():
        tex.release()
    kept.clear()                                                  # drawn again from a fresh upload
    np.testing.assert_array_equal(second, first)
    np.testing.assert_array_equal(session.render(spec).image, first)
    own = make_spec(spec, base_color_texture=_png(tmp_path / "c.png", (200, 90, 40)))
    assert not texture_set(own).shared
    session.render(own)
    assert len(kept) == 1 <= KEPT_UPLOADS                          # its own PNG set was not kept


def _box_levels_float64(img, srgb):
    """Independent levels: each texel of level k the mean of the 2^k x 2^k level-0 texels under
    it, colour decoded by the sRGB curve in float64 and encoded back, rounded to codes."""
    from sdfpbr.oracle.display import srgb_oetf
    linear = img.astype(np.float64)
    if srgb:
        linear[..., :3] = 255.0 * srgb_eotf(img[..., :3] / 255.0)
    out, k = [], 1
    while (img.shape[0] >> k) or (img.shape[1] >> k):
        h, w = max(1, img.shape[0] >> k), max(1, img.shape[1] >> k)
        fy, fx = img.shape[0] // h, img.shape[1] // w
        mean = linear.reshape(h, fy, w, fx, 4).mean(axis=(1, 3))
        if srgb:
            mean[..., :3] = 255.0 * srgb_oetf(mean[..., :3] / 255.0)
        out.append(np.rint(mean))
        k += 1
    return out


@pytest.mark.parametrize("srgb", [True, False], ids=["srgb", "linear"])
def test_mip_levels_are_box_means_of_level_0_colour_in_linear_light(srgb):
    """The levels made for an upload against float64 box means (GL's sizes down to 1 x 1);
    float32 sums may land a code the other way only where the exact mean is within 2e-5 of a
    half code: at most one code, on a handful of texels. A one-texel checker of 0 and 255 is
    code 188 one level down where it is sRGB (half the light), 128 where it is linear."""
    from sdfpbr.gpu.textures import mip_levels
    img = np.random.default_rng(7).integers(0, 256, (64, 128, 4), dtype=np.uint8)
    ours, want = mip_levels(img, srgb), _box_levels_float64(img, srgb)
    assert [a.shape for a in ours] == [w.shape for w in want] and ours[-1].shape == (1, 1, 4)
    diff = np.concatenate([np.abs(a.astype(int) - w).ravel() for a, w in zip(ours, want)])
    assert diff.max() <= 1 and np.count_nonzero(diff) <= 3
    checker = np.zeros((4, 8, 4), np.uint8)
    checker[(np.indices((4, 8)).sum(axis=0) % 2) == 1] = 255
    assert (mip_levels(checker, srgb)[0][..., :3] == (188 if srgb else 128)).all()
    odd = mip_levels(np.full((5, 7, 4), 77, np.uint8), srgb)    # GL's sizes for odd sides, a flat map stays flat
    assert [a.shape[:2] for a in odd] == [(2, 3), (1, 1)] and all((a == 77).all() for a in odd)


READ_2D_LEVELS = """#version 450
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Out { vec4 texel[]; };
uniform sampler2D u_map;
uniform int u_levels;
void main() {
    int at = 0;
    for (int k = 1; k < u_levels; ++k) {
        ivec2 size = textureSize(u_map, k);
        for (int y = 0; y < size.y; ++y)
            for (int x = 0; x < size.x; ++x) texel[at++] = texelFetch(u_map, ivec2(x, y), k);
    }
}
"""


@pytest.mark.parametrize("backend", ["egl", pytest.param("osmesa", marks=pytest.mark.requires_backend("osmesa"))])
@pytest.mark.parametrize("loader", [True, False], ids=["glTexImage2D", "build_mipmaps"])
def test_a_maps_levels_are_uploaded_as_made_and_read_back_through_the_sampler(backend, loader):
    """upload() gives each map the levels mip_levels made (no glGenerateMipmap: a blit shader's
    compile per format on llvmpipe, 0.3 s of a cold textured chart); without a GL loader it
    falls back to build_mipmaps, whose levels GL filters from the level above rounded: within
    half a code a level of ours (2 codes over these 4 levels). The colour map is read through
    its sRGB decode (the driver's curve, within srgb_decode_window)."""
    from sdfpbr.gpu.gl import create_context
    from sdfpbr.gpu.textures import TextureSet, mip_levels, upload
    rng = np.random.default_rng(3)
    maps = {name: rng.integers(0, 256, (8, 16, 4), dtype=np.uint8) for name in ("base", "orm", "normal")}
    ctx = create_context(backend)
    try:
        with ctx:
            if not loader:
                ctx.extra = {**ctx.extra, "gl_function": None}
            uploaded = upload(ctx, TextureSet(maps))
            read = ctx.compute_shader(READ_2D_LEVELS)
            for name, uniform in (("base", "u_base_color_map"), ("orm", "u_orm_map"), ("normal", "u_normal_map")):
                levels = mip_levels(maps[name], srgb=name == "base")
                out = ctx.buffer(reserve=sum(a.size for a in levels) * 4)
                out.bind_to_storage_buffer(0)
                uploaded[uniform].use(0)
                read["u_map"], read["u_levels"] = 0, len(levels) + 1
                read.run(1)
                ctx.memory_barrier()
                got = 255.0 * np.frombuffer(out.read(), np.float32)
                want = np.concatenate([a.ravel() for a in levels]).astype(np.float64)
                if name == "base":   # compare in linear light: the sampler decodes
                    colour = np.arange(want.size) % 4 < 3
                    low, high = (255.0 * w for w in srgb_decode_window(want[colour]))
                    want[colour] = 255.0 * srgb_eotf(want[colour] / 255.0)
                    tolerance = np.full(want.size, 1e-3 if loader else 2.0 + 1e-3)   # alpha: linear
                    tolerance[colour] = np.maximum(want[colour] - low, high - want[colour])
                    if not loader:
                        tolerance[colour] += 2.0 * 2.4   # two codes at the curve's steepest slope
                else:
                    tolerance = 1e-3 if loader else 2.0 + 1e-3
                assert (np.abs(got - want) <= tolerance).all(), (name, np.abs(got - want).max())
                out.release()
            assert ctx.error == "GL_NO_ERROR"
    finally:
        ctx.release()
