"""A TOML object naming a whole glTF file (`[[objects]] file = "Duck.glb"`) keeps the file's own materials and
textures, placed by its nodes and then the object's transform; naming a `material` keeps the old meaning."""

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.scene.scene import Scene

from tests.gltftools import QUAD, gltf_file, png_bytes, textured_quad

RED = {"name": "red paint", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.2, 0.1, 1.0], "metallicFactor": 0.25, "roughnessFactor": 0.4}}


def scene_of(tmp_path, **obj):
    return Scene.from_dict({"objects": [{"type": "mesh", **obj}]}, base_dir=tmp_path)


def test_a_gltf_file_object_keeps_the_files_material(tmp_path):
    gltf_file(tmp_path, [{"mesh": 0, "translation": [0, 0, -1]}], materials=[RED])
    scene = scene_of(tmp_path, file="scene.gltf", translate=[2, 0, 0], scale=3)
    (mesh,) = scene.objects
    m = scene.materials[mesh.material]
    assert m.base_color == pytest.approx((0.9, 0.2, 0.1)) and (m.metallic, m.roughness) == pytest.approx((0.25, 0.4))
    # the node's translation, then the object's scale and translate: 3 (QUAD + (0, 0, -1)) + (2, 0, 0)
    expected = 3 * (QUAD.astype(np.float64) + [0, 0, -1]) + [2, 0, 0]
    np.testing.assert_allclose(np.sort(mesh.vertices, axis=0), np.sort(expected, axis=0), atol=1e-6)


def test_a_named_material_still_paints_every_triangle_of_the_file(tmp_path):
    gltf_file(tmp_path, [{"mesh": 0}], materials=[RED])
    scene = Scene.from_dict(
        {"materials": {"blue": {"diffuse": [0.1, 0.2, 0.9]}}, "objects": [{"type": "mesh", "file": "scene.gltf", "material": "blue"}]},
        base_dir=tmp_path,
    )
    assert [o.material for o in scene.objects] == ["blue"]


def test_a_gltf_file_object_keeps_its_textures(tmp_path):
    texels = np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 255]]], np.uint8)
    material = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}
    textured_quad(tmp_path, material, [png_bytes(texels)], name="model.gltf")
    scene = scene_of(tmp_path, file="model.gltf")
    (mesh,) = scene.objects
    ref = scene.materials[mesh.material].base_color_texture
    assert ref is not None and mesh.uvs is not None
    np.testing.assert_allclose(scene.textures[ref.index].pixels.shape[:2], (2, 2))


def test_a_bad_key_on_a_gltf_file_object_is_still_refused(tmp_path):
    gltf_file(tmp_path, [{"mesh": 0}], materials=[RED])
    with pytest.raises(UsageError, match="zz"):
        scene_of(tmp_path, file="scene.gltf", zz=1)
