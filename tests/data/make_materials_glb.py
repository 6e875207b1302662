"""Writes charts/materials.glb (the gallery's and the tests' asset): six glTF materials, one per lobe the chart renders
(run with `python tests/data/make_materials_glb.py`; the tests also build assets with gltf_asset())."""
from pathlib import Path

import pygltflib


def gltf_asset(materials) -> pygltflib.GLTF2:
    """A glTF 2.0 document holding ``materials`` (pygltflib Material objects) and no meshes."""
    return pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0", generator="sdfpbr tests"), materials=list(materials))


def pbr(base, metallic, roughness):
    return pygltflib.PbrMetallicRoughness(baseColorFactor=[*base, 1.0], metallicFactor=metallic,
                                          roughnessFactor=roughness)


MATERIALS = [
    pygltflib.Material(name="red plastic", pbrMetallicRoughness=pbr((0.8, 0.05, 0.05), 0.0, 0.4)),
    pygltflib.Material(name="gold", pbrMetallicRoughness=pbr((1.0, 0.766, 0.336), 1.0, 0.25)),
    pygltflib.Material(name="car paint", pbrMetallicRoughness=pbr((0.05, 0.1, 0.5), 0.6, 0.5),
                       extensions={"KHR_materials_clearcoat": {"clearcoatFactor": 1.0,
                                                               "clearcoatRoughnessFactor": 0.05}}),
    pygltflib.Material(name="velvet", pbrMetallicRoughness=pbr((0.25, 0.02, 0.08), 0.0, 0.9),
                       extensions={"KHR_materials_sheen": {"sheenColorFactor": [1.0, 0.4, 0.6],
                                                           "sheenRoughnessFactor": 0.5}}),
    pygltflib.Material(name="gem", pbrMetallicRoughness=pbr((0.05, 0.3, 0.1), 0.0, 0.05),
                       extensions={"KHR_materials_ior": {"ior": 2.4},
                                   "KHR_materials_specular": {"specularColorFactor": [1.0, 0.9, 0.7]}}),
    pygltflib.Material(name="lamp", pbrMetallicRoughness=pbr((0.9, 0.9, 0.9), 0.0, 0.5),
                       emissiveFactor=[1.0, 0.6, 0.2],
                       extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 3.0}}),
]

if __name__ == "__main__":
    out = Path(__file__).parents[2] / "charts" / "materials.glb"
    gltf_asset(MATERIALS).save_binary(str(out))
    print(out)
