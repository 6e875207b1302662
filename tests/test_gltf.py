"""glTF materials as chart cells (the gltf extra): factors and KHR lobes read with pygltflib,
one labelled cell per material, and one-line errors for what cannot be charted."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sdfpbr.errors import SpecError
from sdfpbr.spec.chart_spec import make_spec

pygltflib = pytest.importorskip("pygltflib", reason="the gltf extra (pygltflib) is not installed")
sys.path.insert(0, str(Path(__file__).parent / "data"))
from make_materials_glb import MATERIALS, gltf_asset, pbr  # noqa: E402

GLB = Path(__file__).parent / "data" / "materials.glb"


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


def test_a_gltf_json_file_with_texture_and_alpha_mode_is_charted_and_says_what_it_left_out(tmp_path, cache_dir):
    doc = gltf_asset([pygltflib.Material(name="leaf", pbrMetallicRoughness=pbr((0.1, 0.5, 0.1), 0.0, 0.6),
                                         alphaMode="MASK", normalTexture=pygltflib.NormalMaterialTexture(index=0))])
    path = tmp_path / "leaf.gltf"
    doc.save_json(str(path))
    out = tmp_path / "leaf.png"
    r = subprocess.run([sys.executable, "-m", "sdfpbr", "chart", "--gltf", str(path), "-o", str(out),
                        "--size", "96x96"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "leaf: normalTexture is not charted" in r.stderr and "leaf: alphaMode MASK" in r.stderr
    assert out.stat().st_size > 0


@pytest.mark.parametrize("args, needle", [
    (["--gltf", "missing.glb"], "is not an existing .gltf or .glb file"),
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
