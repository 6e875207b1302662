"""glTF materials as chart cells (the gltf extra): factors and KHR lobes read with pygltflib,
one labelled cell per material, and one-line errors for what cannot be charted."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sdfpbr.errors import SpecError
from sdfpbr.spec.chart_spec import make_spec

from helpers import PROGRAM_RTOL, png_bytes, textured, textured_glb

pygltflib = pytest.importorskip("pygltflib", reason="the gltf extra (pygltflib) is not installed")
sys.path.insert(0, str(Path(__file__).parent / "data"))
from make_materials_glb import MATERIALS, gltf_asset, pbr  # noqa: E402

GLB = Path(__file__).parents[1] / "charts" / "materials.glb"


def test_the_shipped_asset_is_what_its_script_writes(tmp_path):
    gltf_asset(MATERIALS).save_binary(str(tmp_path / "m.glb"))
    assert (tmp_path / "m.glb").read_bytes() == GLB.read_bytes()


def test_every_material_is_one_cell_with_its_factors_and_lobes():
    spec = make_spec(gltf=str(GLB))
    assert (spec.rows, spec.cols) == (2, 3)
    cells = [m for row in spec.cell_materials() for m in row]
    assert [m.name for m in cells] == ["red plastic", "gold", "car paint", "velvet", "gem", "lamp"]
    gold, paint, velvet, gem, lamp = cells[1:]
    assert gold.base_color == (1.0, 0.766, 0.336) and gold.metallic == 1.0 and gold.roughness == 0.25
    assert (paint.clearcoat, paint.clearcoat_roughness) == (1.0, 0.05)
    assert velvet.sheen_color == (1.0, 0.4, 0.6) and velvet.sheen_roughness == 0.5
    assert gem.ior == 2.4 and gem.specular_color == (1.0, 0.9, 0.7) and gem.specular == 1.0
    assert lamp.emissive == (1.0, 0.6, 0.2) and lamp.emissive_strength == 3.0


def test_named_materials_in_their_order_and_a_misspelt_name_suggested():
    spec = make_spec(gltf=str(GLB), gltf_materials="velvet,gold")
    assert [m.name for row in spec.cell_materials() for m in row] == ["velvet", "gold"]
    assert (spec.rows, spec.cols) == (1, 2)
    with pytest.raises(SpecError, match="no material 'glod'.*did you mean 'gold'"):
        make_spec(gltf=str(GLB), material="glod")


@pytest.mark.parametrize("given", [dict(x_axis="clearcoat"), dict(materials="gold,copper"),
                                   dict(base_color=(1.0, 0.0, 0.0)), dict(roughness=(0.2, 0.2)),
                                   dict(sheen_color=(1.0, 0.0, 0.0)), dict(base_colors=[(1.0, 0.0, 0.0)] * 6)])
def test_what_the_assets_materials_decide_is_refused_beside_gltf(given):
    """An asset's materials set every material parameter of their cells: a spec that charts one
    and sets an axis, a base colour, a preset or a factor would have it ignored, so it is
    refused in one line."""
    key = next(iter(given))
    with pytest.raises(SpecError, match=f"gltf charts the asset's own materials.*{key} applies to charts without gltf"):
        make_spec(gltf=str(GLB), **given)


def test_a_bug_or_a_furnace_on_an_asset_leaves_its_materials_to_it():
    """A bug's visibility settings (clearcoat-adds: a coat down the rows) and the white furnace's
    white base would set what the asset's materials decide: on an asset they leave them to it."""
    from sdfpbr.spec.chart_spec import with_bug
    from sdfpbr.devtools.energy import furnace_spec
    spec = make_spec(gltf=str(GLB))
    coated = with_bug(spec, "clearcoat-adds")
    assert coated.bugs == ("clearcoat-adds",) and coated.cell_materials() == spec.cell_materials()
    furnace = furnace_spec(spec)
    assert furnace.env == "uniform" and furnace.cell_materials() == spec.cell_materials()


def test_an_asset_whose_materials_make_no_grid_is_refused_by_its_count():
    """More materials than a row holds (a prime count makes one row): the message names the
    count and --material, not the cols the user never gave."""
    from sdfpbr.spec.gltf import grid_for
    assert grid_for(6) == (2, 3) and grid_for(64 * 64) == (64, 64)
    for count in (67, 5000):
        with pytest.raises(SpecError, match=f"the asset's {count} materials make a .* grid, "
                                            "wider than 64 cells.*--material"):
            grid_for(count)


@pytest.mark.parametrize("change, message", [
    (lambda doc: setattr(doc.asset, "version", "1.0"), "is glTF version '1.0'; sdfpbr reads glTF 2.x"),
    (lambda doc: setattr(doc, "extensionsRequired", ["KHR_materials_transmission"]),
     "requires 'KHR_materials_transmission', which sdfpbr does not chart"),
    (lambda doc: setattr(doc, "extensionsRequired", ["EXT_texture_webp"]),
     "requires 'EXT_texture_webp', which sdfpbr does not chart"),
])
def test_an_asset_sdfpbr_cannot_read_faithfully_is_refused(tmp_path, change, message):
    """Another major version, or a material or texture extension the asset requires (a loader
    must refuse it, glTF 2.0 section 3.12) that sdfpbr does not implement: one line, not a
    silent chart. What it requires of its meshes, and what sdfpbr reads, are charted."""
    doc = gltf_asset([pygltflib.Material(name="leaf", pbrMetallicRoughness=pbr((0.1, 0.5, 0.1), 0.0, 0.6))])
    change(doc)
    doc.save_json(str(tmp_path / "leaf.gltf"))
    with pytest.raises(SpecError, match=message):
        make_spec(gltf=str(tmp_path / "leaf.gltf"))
    doc.extensionsRequired = ["KHR_texture_transform", "KHR_draco_mesh_compression", "KHR_mesh_quantization"]
    doc.asset.version = "2.1"
    doc.save_json(str(tmp_path / "fine.gltf"))
    assert make_spec(gltf=str(tmp_path / "fine.gltf")).rows == 1


def test_a_gltf_json_file_with_an_extension_it_does_not_chart_is_charted_and_says_so(tmp_path, cache_dir):
    doc = gltf_asset([pygltflib.Material(name="leaf", pbrMetallicRoughness=pbr((0.1, 0.5, 0.1), 0.0, 0.6),
                                         extensions={"KHR_materials_transmission": {"transmissionFactor": 0.5}})])
    path = tmp_path / "leaf.gltf"
    doc.save_json(str(path))
    out = tmp_path / "leaf.png"
    r = subprocess.run([sys.executable, "-m", "sdfpbr", "chart", "--gltf", str(path), "-o", str(out),
                        "--size", "96x96"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "material 'leaf' KHR_materials_transmission is not charted" in r.stderr
    assert out.stat().st_size > 0


@pytest.mark.parametrize("args, needle", [
    (["--gltf", "missing.glb"], "gltf missing.glb does not exist"),
    (["--material", "gold"], "give gltf too"),
    (["--gltf", str(GLB), "--rows", "4"], "rows x cols must be 6"),
])
def test_bad_gltf_input_is_one_line_exit_2_no_file(tmp_path, args, needle):
    out = tmp_path / "x.png"
    r = subprocess.run([sys.executable, "-m", "sdfpbr", "chart", *args, "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and needle in r.stderr, r.stderr
    assert not out.exists()


def test_a_file_that_is_not_gltf_is_one_line(tmp_path):
    bad = tmp_path / "bad.glb"
    bad.write_bytes(b"not a glb at all")
    with pytest.raises(SpecError, match="cannot be read as glTF 2.0"):
        make_spec(gltf=str(bad))


def test_cells_render_their_own_material(session):
    """The gold cell is gold-tinted (a metal: its colour is its base colour), the lamp is the
    brightest cell (it emits 3 x its colour), the velvet's rim is lighter than its centre
    (sheen), each as the float values say."""
    spec = make_spec(gltf=str(GLB), size="240x160", labels=False)
    res = session.render(spec)
    aov, hdr = res.aov, res.hdr.astype(np.float64)
    def cell(r, c, m=None):
        mask = (aov["row"] == r) & (aov["col"] == c) & (aov["coverage"] == 1)
        return hdr[mask & (m if m is not None else True)][:, :3]
    gold = cell(0, 1).mean(0)
    assert gold[0] > gold[1] > gold[2]
    means = [cell(r, c).mean() for r in range(2) for c in range(3)]
    # Reflected light only adds to the emission: every lamp pixel is at least 3 x (1, 0.6, 0.2).
    assert np.argmax(means) == 5 and (cell(1, 2) >= np.array([3.0, 1.8, 0.6]) * (1 - 1e-4)).all()
    rim, centre = aov["ndotv"] < 0.3, aov["ndotv"] > 0.9
    assert cell(1, 0, rim).mean() > cell(1, 0, centre).mean()


# ---- textures --------------------------------------------------------------------------------

LAYER = (1024, 512)   # gpu.textures.GLTF_LAYER_SIZE: a map's texels on the sphere


def pattern(seed: int) -> np.ndarray:
    """A layer-sized RGB pattern: smooth bands plus noise, so a misplaced texel shows."""
    rng = np.random.default_rng(seed)
    h, w = LAYER[1], LAYER[0]
    j, i = np.mgrid[:h, :w]
    img = np.stack([128 + 100 * np.sin(i / 40.0), 128 + 100 * np.cos(j / 25.0), 60 + 0 * i], -1)
    return np.clip(img + rng.integers(-20, 21, img.shape), 0, 255).astype(np.uint8)


def largest_step_from_png(session, glb: str, png: np.ndarray) -> int:
    """The largest 8-bit difference between the asset's one-cell chart and the chart of a
    white, rough-0.5 dielectric with ``png`` as --base-color-texture."""
    import tempfile
    kw = dict(size="160x160", labels=False)
    got = session.render(make_spec(gltf=glb, **kw)).image
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "want.png"
        path.write_bytes(png_bytes(png))
        want = session.render(make_spec(base_color_texture=str(path), base_color=(1.0, 1.0, 1.0),
                                        metallic=(0.0, 0.0), roughness=(0.5, 0.5), rows=1, cols=1, **kw)).image
    return int(np.abs(got.astype(int) - want).max())


def test_a_base_colour_texture_is_the_png_the_asset_holds(session, tmp_path):
    """A layer-sized image in the .glb's buffer lands on the sphere texel for texel: the chart
    equals the same image given as --base-color-texture on a white, rough-0.5 dielectric."""
    img = pattern(1)
    glb = textured_glb(tmp_path / "t.glb", [png_bytes(img)], [textured()])
    assert largest_step_from_png(session, glb, img) <= 1


@pytest.mark.parametrize("source", ["data URI", "file beside the .gltf"])
def test_a_gltf_files_image_from_a_data_uri_or_a_file_beside_it(session, tmp_path, source):
    """The same image given by a .gltf (JSON) as a base64 data URI, or as a PNG file named
    relative to the .gltf: the chart equals that image as --base-color-texture, as a .glb's
    buffer view does."""
    import base64
    img = pattern(3)
    data = png_bytes(img)
    doc = gltf_asset([textured()])
    if source == "data URI":
        uri = "data:image/png;base64," + base64.b64encode(data).decode()
    else:
        (tmp_path / "maps").mkdir()
        (tmp_path / "maps" / "colour.png").write_bytes(data)
        uri = "maps/colour.png"
    doc.images = [pygltflib.Image(uri=uri)]
    doc.textures = [pygltflib.Texture(source=0)]
    path = tmp_path / "asset.gltf"
    doc.save_json(str(path))
    assert largest_step_from_png(session, str(path), img) <= 1


def test_khr_texture_transform_and_wrap_are_applied(session, tmp_path):
    """scale (2, 1) with repeat wrap: the sphere's u runs twice over the image, so the layer's
    texel i is the image's texels 2i and 2i + 1 averaged (the sampler sets no minFilter: the
    mipmapped read, in linear light for a colour map); offset (0, 0.25) with clamp shifts v
    down a quarter and holds the last row. Computed here from the image alone, given as a PNG:
    the chart must match it."""
    from sdfpbr.oracle.display import srgb_eotf, srgb_oetf
    img = pattern(2)
    h = img.shape[0]
    linear = srgb_eotf(img / 255.0)
    doubled = 255.0 * srgb_oetf((linear[:, 0::2] + linear[:, 1::2]) / 2.0)
    doubled = np.concatenate([doubled, doubled], 1)
    rows = np.clip(np.arange(h) + h // 4, 0, h - 1)    # v + 0.25 lands exactly a quarter of the rows down
    want_img = np.rint(doubled[rows]).astype(np.uint8)
    transform = {"KHR_texture_transform": {"scale": [2.0, 1.0], "offset": [0.0, 0.25]}}
    sampler = pygltflib.Sampler(wrapS=10497, wrapT=33071)
    glb = textured_glb(tmp_path / "t.glb", [png_bytes(img)], [textured(transform)], [sampler])
    assert largest_step_from_png(session, glb, want_img) <= 1


def layer_of(glb: str, kind: str) -> np.ndarray:
    """The asset's one material's layer of map ``kind`` as the chart uploads it (uint8)."""
    from sdfpbr.gpu.textures import gltf_set
    return gltf_set(make_spec(gltf=glb).gltf_maps()).images[kind]


@pytest.mark.parametrize("min_filter", [None, 9987, 9984, 9729, 9728])
def test_a_minified_texture_follows_its_samplers_min_filter(tmp_path, min_filter):
    """An image three times the layer's size each way (noise: every texel differs). A mipmap
    mode, or none given, reads each layer texel as the mean of the 3 x 3 image texels under it;
    NEAREST and LINEAR read level 0 at the texel's centre, which is image texel (3i + 1, 3j + 1)
    exactly, aliasing as GL does. The base colour (sRGB) is averaged in linear light, as a GL
    sRGB texture's mipmaps are; the metallic-roughness map (linear data) as it is stored."""
    from sdfpbr.oracle.display import srgb_eotf, srgb_oetf
    rng = np.random.default_rng(5)
    w, h = LAYER[0] * 3, LAYER[1] * 3
    colour, mr = rng.integers(0, 256, (h, w, 3), dtype=np.uint8), rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    m = textured(metallicRoughnessTexture=pygltflib.TextureInfo(index=1))
    sampler = pygltflib.Sampler(minFilter=min_filter)
    glb = textured_glb(tmp_path / "t.glb", [png_bytes(colour), png_bytes(mr)], [m], [sampler, sampler])
    base, orm = layer_of(glb, "base").astype(np.float64), layer_of(glb, "orm").astype(np.float64)
    def blocks(a):   # (h/3, w/3, 3, 3, c): each layer texel's 3 x 3 image texels
        return a.reshape(h // 3, 3, w // 3, 3, -1).swapaxes(1, 2)
    if min_filter in (None, 9987, 9984):
        want_base = 255.0 * srgb_oetf(srgb_eotf(blocks(colour) / 255.0).mean((2, 3)))
        want_mr = blocks(mr.astype(np.float64)).mean((2, 3))
    else:
        want_base, want_mr = colour[1::3, 1::3], mr[1::3, 1::3]
    assert np.abs(base[..., :3] - want_base).max() <= 0.5 + 1e-3    # the layer's rounding to 8 bits
    assert np.abs(orm[..., 1:3] - want_mr[..., 1:3]).max() <= 0.5 + 1e-3


@pytest.mark.parametrize("key, value, allowed", [("wrapS", 7, "33071 clamp"), ("magFilter", 9987, "9728, 9729"),
                                                  ("minFilter", 9730, "9728, 9729, 9984, 9985, 9986, 9987")])
def test_a_sampler_value_glTF_does_not_define_is_named_with_what_is_allowed(tmp_path, key, value, allowed):
    img = np.zeros((4, 8, 3), np.uint8)
    glb = textured_glb(tmp_path / "t.glb", [png_bytes(img)], [textured()], [pygltflib.Sampler(**{key: value})])
    with pytest.raises(SpecError, match=f"baseColorTexture: its sampler's {key} {value} is not a glTF .*{allowed}"):
        make_spec(gltf=glb).gltf_maps()


@pytest.mark.parametrize("min_filter, want", [(None, 188), (9728, 0)])
def test_a_checker_finer_than_the_layer_renders_as_its_mean_or_as_gl_aliases_it(session, tmp_path, min_filter, want):
    """A one-texel black-and-white checker at twice the layer's size: mipmapped, each layer
    texel holds two white texels of four, half the light: sRGB code 188 (not 128, the codes'
    mean), and the chart equals the chart of a plain code-188 image; NEAREST reads texel
    (2i + 1, 2j + 1), black on every one: the sphere renders black."""
    j, i = np.mgrid[:LAYER[1] * 2, :LAYER[0] * 2]
    checker = np.repeat((255 * ((i + j) % 2)).astype(np.uint8)[..., None], 3, -1)
    glb = textured_glb(tmp_path / "t.glb", [png_bytes(checker)], [textured()],
                       [pygltflib.Sampler(minFilter=min_filter)])
    plain = np.full((LAYER[1], LAYER[0], 3), want, np.uint8)
    assert largest_step_from_png(session, glb, plain) <= 1


def test_each_cell_reads_its_own_materials_textures(session, tmp_path):
    """Four materials: a red base-colour texture; a green one with a metallic-roughness texture
    (G roughness 0, B metalness 1) over factors 1, 1; an untextured blue; and the green metal
    by factors alone (roughness 0, metallic 1). Every cell reads its own layer: the red and
    green cells take their texture's colour, the textured metal equals the factor metal below
    it (identical cells: the same pixels), the blue cell keeps its factors."""
    red = np.zeros((8, 16, 3), np.uint8)
    red[..., 0] = 255
    green = np.zeros((8, 16, 3), np.uint8)
    green[..., 1] = 255
    mr = np.zeros((8, 16, 3), np.uint8)
    mr[..., 2] = 255
    plain = pygltflib.Material(name="plain", pbrMetallicRoughness=pbr((0.2, 0.2, 0.9), 0.0, 0.5))
    metal = pygltflib.Material(name="metal", pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
        baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=1.0, roughnessFactor=1.0,
        baseColorTexture=pygltflib.TextureInfo(index=1), metallicRoughnessTexture=pygltflib.TextureInfo(index=2)))
    by_factors = pygltflib.Material(name="factors", pbrMetallicRoughness=pbr((0.0, 1.0, 0.0), 1.0, 0.0))
    glb = textured_glb(tmp_path / "t.glb", [png_bytes(red), png_bytes(green), png_bytes(mr)],
                       [textured(), metal, plain, by_factors])
    spec = make_spec(gltf=glb, size="160x160", labels=False)
    res = session.render(spec)
    aov, hdr = res.aov, res.hdr.astype(np.float64)[..., :3]
    def cell(r, c):
        return hdr[(aov["row"] == r) & (aov["col"] == c) & (aov["coverage"] == 1)]
    r, g, b = cell(0, 0).mean(0), cell(0, 1).mean(0), cell(1, 0).mean(0)
    assert r[0] > 4 * r[1] and g[1] > 4 * g[0] and b[2] > 2 * b[0]
    # The same material by texels and by factors: the same arithmetic in another order. (Its
    # texels are 0 and 255, the ends of the sRGB curve, which decode to 0 and 1.)
    np.testing.assert_allclose(cell(0, 1), cell(1, 1), rtol=PROGRAM_RTOL, atol=PROGRAM_RTOL * cell(1, 1).max())


def test_an_emissive_texture_scales_the_emissive_factor(session, tmp_path):
    """No light but the sphere's own: every sphere pixel is strength x factor x the texel,
    sRGB-decoded (glTF: the emissive texture is sRGB). The texture's left half (u < 0.5) and
    right half differ, so the test also sees that each half lands on its side of the sphere."""
    img = np.zeros((8, 16, 3), np.uint8)
    img[:, :8] = (200, 100, 50)
    img[:, 8:] = (20, 220, 120)
    lamp = pygltflib.Material(name="lamp", pbrMetallicRoughness=pbr((0.0, 0.0, 0.0), 0.0, 1.0),
                              emissiveFactor=[1.0, 0.5, 1.0], emissiveTexture=pygltflib.TextureInfo(index=0),
                              extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}})
    glb = textured_glb(tmp_path / "t.glb", [png_bytes(img)], [lamp], [pygltflib.Sampler(magFilter=9728)])
    spec = make_spec(gltf=glb, size="128x128", labels=False, env="black", ibl=False, ground=False, lights=())
    res = session.render(spec)
    aov, hdr = res.aov, res.hdr.astype(np.float64)[..., :3]
    def srgb_code(linear):   # the sRGB OETF, as 8-bit codes (not rounded)
        c = np.clip(linear, 0.0, 1.0)
        return 255.0 * np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    # u = 0.5 + atan2(n.x, n.z) / 2 pi: u < 0.5 where n.x < 0, the sphere's left half on screen.
    normal_x = aov["normal"][..., 0]
    inside = (aov["coverage"] == 1) & (aov["row"] == 0)
    for side, texel in ((normal_x < -0.2, img[0, 0]), (normal_x > 0.2, img[0, 15])):
        got = hdr[inside & side] / (2.0 * np.array([1.0, 0.5, 1.0]))
        assert len(got) > 500
        # Back to the texel's codes: GL decodes 8-bit sRGB approximately (llvmpipe by a
        # polynomial), so each pixel is held to within half a code of its texel.
        assert np.abs(srgb_code(got) - texel).max() <= 0.5
    # The reference reads the same texels (at level 0, through its own fetch and decode): its
    # sphere is held to the same half code of each texel.
    from sdfpbr.features.reference import render_reference
    ref = render_reference(spec, samples=4, seed=3, session=session).hdr[..., :3]
    for side, texel in ((normal_x < -0.2, img[0, 0]), (normal_x > 0.2, img[0, 15])):
        assert np.abs(srgb_code(ref[inside & side] / (2.0 * np.array([1.0, 0.5, 1.0]))) - texel).max() <= 0.5


# ---- the KHR extensions' textures -------------------------------------------------------------

def constant_png(rgba) -> bytes:
    return png_bytes(np.broadcast_to(np.asarray(rgba, np.uint8), (4, 8, 4)).copy())


def test_khr_textures_scale_their_factors(session, tmp_path):
    """Each extension texture multiplies its factor (glTF): a material whose clearcoat, coat
    roughness, sheen roughness and specular come from constant textures (R, G, A, A of one
    RGBA image, linear 8-bit: exact) and whose sheen and specular colours come from an sRGB
    image of 0 and 255 codes (decoded exactly) equals the material with the products as
    factors and no textures; identical cells, so the same pixels up to float rounding."""
    data = (128, 64, 77, 200)
    ext = lambda t0, t1: {   # noqa: E731
        "KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.5,
                                    **({"clearcoatTexture": {"index": t0}, "clearcoatRoughnessTexture": {"index": t0}}
                                       if t0 is not None else {})},
        "KHR_materials_sheen": {"sheenColorFactor": [1.0, 0.4, 0.6], "sheenRoughnessFactor": 0.8,
                                **({"sheenColorTexture": {"index": t1}, "sheenRoughnessTexture": {"index": t0}}
                                   if t0 is not None else {})},
        "KHR_materials_specular": {"specularFactor": 0.9, "specularColorFactor": [1.0, 0.8, 0.5],
                                   **({"specularTexture": {"index": t0}, "specularColorTexture": {"index": t1}}
                                      if t0 is not None else {})},
        "KHR_materials_ior": {"ior": 2.0}}
    textured_m = pygltflib.Material(name="textured", pbrMetallicRoughness=pbr((0.3, 0.2, 0.1), 0.0, 0.5),
                                    extensions=ext(0, 1))
    products = ext(None, None)
    c = products["KHR_materials_clearcoat"]
    c["clearcoatFactor"] *= data[0] / 255
    c["clearcoatRoughnessFactor"] *= data[1] / 255
    sh = products["KHR_materials_sheen"]
    sh["sheenColorFactor"] = [1.0, 0.0, 0.6]          # x (255, 0, 255)
    sh["sheenRoughnessFactor"] *= data[3] / 255
    sp = products["KHR_materials_specular"]
    sp["specularFactor"] *= data[3] / 255
    sp["specularColorFactor"] = [1.0, 0.0, 0.5]       # x (255, 0, 255)
    by_factors = pygltflib.Material(name="factors", pbrMetallicRoughness=pbr((0.3, 0.2, 0.1), 0.0, 0.5),
                                    extensions=products)
    glb = textured_glb(tmp_path / "khr.glb", [constant_png(data), constant_png((255, 0, 255, 255))],
                       [textured_m, by_factors])
    res = session.render(make_spec(gltf=glb, size="256x128", labels=False))
    aov, hdr = res.aov, res.hdr.astype(np.float64)[..., :3]
    a = hdr[(aov["col"] == 0) & (aov["coverage"] == 1)]
    b = hdr[(aov["col"] == 1) & (aov["coverage"] == 1)]
    assert a.shape == b.shape and a.size > 1000
    # the same products, rounded in another order
    np.testing.assert_allclose(a, b, rtol=PROGRAM_RTOL, atol=PROGRAM_RTOL * b.max())


def test_a_clearcoat_normal_map_tilts_the_coat(session, tmp_path):
    """A constant clearcoat normal texture tilting the coat 25 degrees towards +u (tangent
    (n.z, 0, -n.x), glTF/OpenGL convention) moves the coat's sharp highlight to where the tilted
    normal meets the half vector: predicted here in float64 from the AOV normals, the
    brightest pixel lies within 2 pixels of it (the untilted highlight is far from it)."""
    import math

    from sdfpbr.shading.plan import chart_frame
    tilt = math.radians(25.0)
    texel = np.rint(255 * (0.5 + 0.5 * np.array([math.sin(tilt), 0.0, math.cos(tilt)]))).astype(int)
    light = {"kind": "directional", "direction": [0.3, 0.5, 0.8], "intensity": 3.0, "angular_radius_deg": 0.0}
    def render(with_map):
        coat = {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.08,
                **({"clearcoatNormalTexture": {"index": 0}} if with_map else {})}
        m = pygltflib.Material(name="coat", pbrMetallicRoughness=pbr((0.0, 0.0, 0.0), 0.0, 1.0),
                               extensions={"KHR_materials_clearcoat": coat,
                                           "KHR_materials_specular": {"specularFactor": 0.0}})
        glb = textured_glb(tmp_path / f"coat{with_map}.glb", [constant_png((*texel, 255))], [m])
        spec = make_spec(gltf=glb, size="160x160", labels=False, env="black", ibl=False, ground=False,
                         camera="orthographic", lights=[light])
        return spec, session.render(spec)
    spec, res = render(True)
    n = res.aov["normal"].astype(np.float64)
    inside = res.aov["coverage"] == 1
    t = np.stack([n[..., 2], np.zeros_like(n[..., 0]), -n[..., 0]], -1)
    t /= np.maximum(np.linalg.norm(t, axis=-1, keepdims=True), 1e-9)
    ts = texel / 255.0 * 2 - 1
    coat_n = ts[0] * t + ts[1] * np.cross(n, t) + ts[2] * n
    coat_n /= np.maximum(np.linalg.norm(coat_n, axis=-1, keepdims=True), 1e-12)   # (background: zero normals)
    v = -np.asarray(chart_frame(spec).camera.forward, np.float64)
    l = np.asarray(light["direction"], np.float64) / np.linalg.norm(light["direction"])
    h = (v + l) / np.linalg.norm(v + l)
    predicted = np.where(inside, coat_n @ h, -1.0)
    luminance = np.where(inside, res.hdr[..., :3].astype(np.float64) @ [0.2126, 0.7152, 0.0722], -1.0)
    want = np.array(np.unravel_index(np.argmax(predicted), predicted.shape))
    got = np.array(np.unravel_index(np.argmax(luminance), luminance.shape))
    assert np.abs(got - want).max() <= 2, (got, want)
    _, flat = render(False)
    flat_l = np.where(inside, flat.hdr[..., :3].astype(np.float64) @ [0.2126, 0.7152, 0.0722], -1.0)
    assert np.abs(np.array(np.unravel_index(np.argmax(flat_l), flat_l.shape)) - want).max() > 10


def test_an_occlusion_texture_and_its_strength_darken_the_environment_light_alone(session, tmp_path):
    """glTF: occlusion = 1 + strength (texel R - 1), on indirect light only. Under a uniform
    environment with no lights, floor or AO, each sphere pixel of the occluded material is the
    plain material's times 1 + 0.6 (64 / 255 - 1) (the layer keeps it to 8 bits: within half a
    code); with a light and no environment the two are the same pixels."""
    def materials():
        plain = pygltflib.Material(name="plain", pbrMetallicRoughness=pbr((0.7, 0.5, 0.3), 0.0, 0.4))
        occluded = pygltflib.Material(name="occluded", pbrMetallicRoughness=pbr((0.7, 0.5, 0.3), 0.0, 0.4),
                                      occlusionTexture=pygltflib.OcclusionTextureInfo(index=0, strength=0.6))
        return [occluded, plain]
    glb = textured_glb(tmp_path / "ao.glb", [constant_png((64, 200, 30, 255))], materials())
    kw = dict(gltf=glb, size="192x96", labels=False, ground=False, ao=False, shadows=False)
    want = 1.0 + 0.6 * (64 / 255 - 1.0)
    assert layer_of(glb, "orm")[:512, :, 0].astype(float) == pytest.approx(255 * want, abs=0.5)
    for extra, ratio in ((dict(env="uniform", lights="none"), want), (dict(env="black", ibl=False), 1.0)):
        res = session.render(make_spec(**kw, **extra))
        aov, hdr = res.aov, res.hdr.astype(np.float64)[..., :3]
        a = hdr[(aov["col"] == 0) & (aov["coverage"] == 1)]
        b = hdr[(aov["col"] == 1) & (aov["coverage"] == 1)]
        assert a.shape == b.shape and a.size > 1000 and b.max() > 0.05
        np.testing.assert_allclose(a, b * np.round(255 * want) / 255 if ratio != 1.0 else b, rtol=PROGRAM_RTOL,
                                   atol=PROGRAM_RTOL * b.max())


def test_a_normal_texture_is_scaled_by_its_scale_on_the_layer(tmp_path):
    """glTF: the normal texture's XY times its scale, then normalised. A constant texel
    (200, 128, 255) with scale 0.5 is the tangent-space normal ((200/255 * 2 - 1) / 2,
    (128/255 * 2 - 1) / 2, 255/255 * 2 - 1) normalised, stored 8-bit: within half a code."""
    texel = np.array([200, 128, 255])
    m = pygltflib.Material(name="bumped", pbrMetallicRoughness=pbr((0.5, 0.5, 0.5), 0.0, 0.5),
                           normalTexture=pygltflib.NormalMaterialTexture(index=0, scale=0.5))
    glb = textured_glb(tmp_path / "n.glb", [constant_png((*texel, 255))], [m])
    n = texel / 255.0 * 2.0 - 1.0
    n[:2] *= 0.5
    n /= np.linalg.norm(n)
    layer = layer_of(glb, "normal")[..., :3].astype(float)
    assert np.abs(layer - 255 * (0.5 + 0.5 * n)).max() <= 0.5 + 1e-6


def test_an_image_edited_beside_a_gltf_is_read_again_and_rekeys_its_gallery_image(session, tmp_path, monkeypatch):
    """A .gltf's image may be a file beside it: editing that file alone (the .gltf untouched)
    gives the new image in the same process, and the gallery renders the entry again (its key
    covers the images the asset samples, not only the asset's own bytes)."""
    from sdfpbr.features.gallery.build import build
    monkeypatch.setenv("SDFPBR_CACHE_DIR", str(tmp_path / "cache"))
    charts = tmp_path / "charts"   # a build reads files inside its entries' folder only
    (charts / "maps").mkdir(parents=True)
    image = charts / "maps" / "colour.png"
    image.write_bytes(png_bytes(pattern(4)))
    doc = gltf_asset([textured()])
    doc.images = [pygltflib.Image(uri="maps/colour.png")]
    doc.textures = [pygltflib.Texture(source=0)]
    doc.save_json(str(charts / "asset.gltf"))
    spec = make_spec(gltf=str(charts / "asset.gltf"), size="96x96")
    first_chart = session.render(spec).image
    (charts / "asset.toml").write_text('gltf = "asset.gltf"\nsize = "96x96"\n')
    first = build(charts, tmp_path / "out")
    image.write_bytes(png_bytes(pattern(5)))
    assert not np.array_equal(session.render(spec).image, first_chart)
    again = build(charts, tmp_path / "out")
    assert again["rendered"] == 1 and again["images"][0]["key"] != first["images"][0]["key"]
