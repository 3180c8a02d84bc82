"""A material is either the seed's Whitted material or glTF's metallic-roughness one, never a blend of the two
key sets; both carry emission and an IOR, and the record the kernels read holds each field under its name."""

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.layout import MATERIAL_DTYPE, MATERIAL_MODELS
from clrender.scene.scene import Scene


def material(table: dict):
    return Scene.from_dict({"materials": {"m": table}}).materials["m"]


def test_the_key_set_chooses_the_model():
    assert material({"diffuse": [0.5, 0.5, 0.5]}).model == "phong"
    assert material({"base_color": [0.5, 0.5, 0.5]}).model == "gltf"
    assert material({"roughness": 0.2}).model == "gltf" and material({"roughness": 0.2}).base_color == (1.0, 1.0, 1.0)
    assert material({"emission": [1, 2, 3]}).model == "phong"


def test_mixing_the_two_key_sets_is_refused_naming_both():
    with pytest.raises(UsageError, match=r"materials\.m\.metallic.*Phong key 'diffuse'"):
        material({"diffuse": [0.5, 0.5, 0.5], "metallic": 1.0})


@pytest.mark.parametrize("key, value", [("metallic", 1.5), ("roughness", -0.1), ("transmission", 2), ("emission", [-1, 0, 0])])
def test_out_of_range_metallic_roughness_values_are_refused(key, value):
    with pytest.raises(UsageError, match=f"materials.m.{key}"):
        material({key: value} if key == "emission" else {"base_color": [1, 1, 1], key: value})


def test_the_record_holds_each_field_by_name():
    m = material({"base_color": [0.25, 0.5, 0.75], "metallic": 0.5, "roughness": 0.3, "transmission": 0.1, "emission": [4, 5, 6], "ior": 1.33})
    r = m.pack()
    assert r.dtype == MATERIAL_DTYPE and int(r["model"]) == MATERIAL_MODELS["gltf"]
    np.testing.assert_array_equal(r["base_color"], np.float32([0.25, 0.5, 0.75]))
    np.testing.assert_array_equal(r["kd"], r["base_color"])  # the Whitted integrator draws the base colour
    assert [float(r[k]) for k in ("metallic", "roughness", "transmission", "ior")] == [0.5, np.float32(0.3), np.float32(0.1), np.float32(1.33)]
    np.testing.assert_array_equal(r["emission"], [4, 5, 6])
    phong = material({"diffuse": [0.1, 0.2, 0.3], "specular": [0.4, 0.4, 0.4], "shininess": 8}).pack()
    assert int(phong["model"]) == MATERIAL_MODELS["phong"]
    np.testing.assert_array_equal(phong["base_color"], phong["kd"])
