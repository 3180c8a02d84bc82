"""`type = "conductor" | "coated_diffuse" | "thin_dielectric"` materials (scene/materials.py, docs/materials.md): what
they pack for the kernels, the Whitted stand-ins, the `smith` key of GGX materials, and one line for bad input."""

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.layout import BSDF_LOBES, MATERIAL_MODELS, SMITH_MODELS
from clrender.scene.scene import Scene

from tests.reference import bsdf64 as ref


def packed(material: dict) -> np.ndarray:
    scene = {"materials": {"m": material}, "objects": [{"type": "sphere", "center": [0, 0, -3], "radius": 1, "material": "m"}]}
    return Scene.from_dict(scene).materials["m"].pack()


def test_a_conductor_packs_its_complex_ior_and_whitted_draws_its_normal_reflectance():
    eta, k = [0.143119, 0.374957, 1.44248], [3.98316, 2.38572, 1.60322]
    r = packed({"type": "conductor", "eta": eta, "k": k, "roughness": 0.3, "tint": [1, 0.5, 1], "smith": "separable"})
    assert int(r["model"]) == MATERIAL_MODELS["conductor"] and int(r["smith"]) == SMITH_MODELS["separable"]
    np.testing.assert_allclose(r["eta"], eta, rtol=1e-6)
    np.testing.assert_allclose(r["k"], k, rtol=1e-6)
    assert r["roughness"] == pytest.approx(0.3)
    f0 = ref.fresnel_conductor(1.0, np.array(eta), np.array(k)) * [1, 0.5, 1]
    np.testing.assert_allclose(r["kd"], f0, rtol=1e-6)  # the Whitted stand-in: Lambert of the normal reflectance
    assert r["mirror"] == 0 and r["transparency"] == 0 and not r["ks"].any()


def test_a_coated_diffuse_packs_mitsubas_coat():
    smooth = packed({"type": "coated_diffuse", "diffuse": [0.5, 0.2, 0.1], "ior": 1.5})
    assert int(smooth["model"]) == MATERIAL_MODELS["coated_diffuse"] and smooth["roughness"] == 0
    assert smooth["coat_internal"] == pytest.approx(ref.coat_fdr(1 / 1.5), rel=1e-6)
    assert smooth["coat_weight"] == pytest.approx(1 / (1 + np.mean([0.5, 0.2, 0.1])), rel=1e-6)
    np.testing.assert_allclose(smooth["kd"], [0.5, 0.2, 0.1])  # the Whitted stand-in and the path tracer's base
    rough = packed({"type": "coated_diffuse", "diffuse": [0.5, 0.2, 0.1], "ior": 1.5, "roughness": 0.3, "nonlinear": True})
    assert int(rough["nonlinear"]) == 1 and 0 < rough["coat_internal"] < 1
    mu = np.maximum(1e-6, np.linspace(0, 1, len(rough["coat_transmittance"])))
    for i in (3, 60):
        assert rough["coat_transmittance"][i] == pytest.approx(ref.rough_interface(mu[i], 1.5, 0.09, "correlated", True), abs=2e-3)


def test_a_thin_dielectric_is_drawn_by_whitted_as_a_clear_pass_through():
    r = packed({"type": "thin_dielectric", "ior": 1.33, "tint": [1, 1, 0.5], "transmittance": [0.9, 0.9, 0.9]})
    assert int(r["model"]) == MATERIAL_MODELS["thin_dielectric"] and r["lobe_ior"] == pytest.approx(1.33)
    assert r["transparency"] == 1 and r["ior"] == 1 and not r["kd"].any()
    np.testing.assert_allclose(r["transmit_tint"], 0.9)


def test_smith_on_a_metallic_roughness_material_and_the_default():
    assert int(packed({"base_color": [1, 1, 1], "smith": "separable"})["smith"]) == 1
    assert int(packed({"base_color": [1, 1, 1]})["smith"]) == 0
    assert int(packed({"type": "gltf"})["model"]) == MATERIAL_MODELS["gltf"]
    assert int(packed({"type": "phong", "diffuse": [1, 0, 0]})["model"]) == MATERIAL_MODELS["phong"] == 0
    assert sorted(BSDF_LOBES.values()) == list(range(len(BSDF_LOBES)))  # one kernel code a lobe, none skipped


@pytest.mark.parametrize(
    "material, words",
    [
        ({"type": "velvet"}, ["materials.m.type", "'velvet'", "'coated_diffuse'"]),
        ({"type": "conductor", "diffuse": [1, 1, 1]}, ["materials.m.diffuse", "unknown key", "eta"]),
        ({"type": "thin_dielectric", "roughness": 0.2}, ["materials.m.roughness", "unknown key", "transmittance"]),
        ({"type": "conductor", "smith": "fancy"}, ["materials.m.smith", "'fancy'", "'separable'"]),
        ({"type": "coated_diffuse", "ior": 1.0, "roughness": 0.5}, ["materials.m.ior", "rough coat"]),
        ({"type": "conductor", "eta": [1, 2]}, ["materials.m.eta"]),
        ({"diffuse": [1, 1, 1], "smith": "separable"}, ["materials.m.smith", "GGX"]),
        ({"diffuse": [1, 1, 1], "tint": [1, 1, 1]}, ["materials.m.tint", "conductor"]),
        ({"type": "phong", "base_color": [1, 1, 1]}, ["materials.m.base_color", "Phong material"]),
        ({"type": "seed", "base_color": [1, 1, 1]}, ["materials.m.base_color", "Phong material"]),
        ({"type": "coated_diffuse", "nonlinear": 1}, ["materials.m.nonlinear", "true or false"]),
    ],
)
def test_bad_materials_give_one_line_naming_the_key(material, words):
    with pytest.raises(UsageError) as info:
        packed(material)
    message = str(info.value)
    assert "\n" not in message
    for w in words:
        assert w in message, message
