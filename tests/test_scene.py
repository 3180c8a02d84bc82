"""Scene files and dicts: the same structure, and clear errors for bad input."""

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.scene.scene import Mesh, Scene, Sphere, bundled_scenes

TRIANGLE_OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def test_toml_file_and_dict_give_the_same_scene(tmp_path):
    text = """
width = 32
height = 24
ambient = [0.1, 0.1, 0.1]
[materials.glass]
transparency = 0.9
ior = 1.5
[[lights]]
type = "area"
corner = [0, 5, 0]
edge_a = [1, 0, 0]
edge_b = [0, 0, 1]
[[objects]]
type = "sphere"
center = [0, 0, -3]
radius = 1
material = "glass"
"""
    path = tmp_path / "s.toml"
    path.write_text(text)
    from_file = Scene.from_file(path)
    import tomllib

    from_dict = Scene.from_dict(tomllib.loads(text))
    assert from_file.objects == from_dict.objects
    assert from_file.lights == from_dict.lights
    assert from_file.materials == from_dict.materials
    assert from_file.lights[0].samples == 5  # the seed's default
    assert isinstance(from_file.objects[0], Sphere)


def test_mesh_paths_are_relative_to_the_scene_file(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "tri.obj").write_text(TRIANGLE_OBJ)
    (tmp_path / "s.toml").write_text('[[objects]]\ntype = "mesh"\nfile = "meshes/tri.obj"\ntranslate = [1, 2, 3]\nscale = 2\n')
    scene = Scene.from_file(tmp_path / "s.toml")
    mesh = scene.objects[0]
    assert isinstance(mesh, Mesh)
    np.testing.assert_allclose(mesh.vertices, [[1, 2, 3], [3, 2, 3], [1, 4, 3]])


def test_rotation_turns_x_into_y_about_z(tmp_path):
    (tmp_path / "tri.obj").write_text(TRIANGLE_OBJ)
    scene = Scene.from_dict({"objects": [{"type": "mesh", "file": "tri.obj", "rotate": [0, 0, 90]}]}, base_dir=tmp_path)
    np.testing.assert_allclose(scene.objects[0].vertices[1], [0, 1, 0], atol=1e-12)


@pytest.mark.parametrize(
    "data, words",
    [
        ({"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "colour": 1}]}, ["objects[0].colour", "unknown key"]),
        ({"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "gold"}]}, ["unknown material 'gold'"]),
        ({"objects": [{"type": "sphere", "center": [0, 0], "radius": 1}]}, ["objects[0].center", "3 numbers"]),
        ({"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": "big"}]}, ["objects[0].radius", "expected a number"]),
        ({"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": -1}]}, ["objects[0].radius", "> 0"]),
        ({"objects": [{"type": "cone"}]}, ["objects[0].type", "'cone'"]),
        ({"materials": {"glass": {"ior": 0}}}, ["materials.glass.ior", "> 0"]),
        ({"materials": {"glass": {"ior": -1.5}}}, ["materials.glass.ior"]),
        ({"materials": {"m": {"transparency": 1.5}}}, ["materials.m.transparency", "<= 1"]),
        ({"lights": [{"type": "spot"}]}, ["lights[0].type", "'spot'"]),
        ({"lights": [{"type": "point"}]}, ["lights[0].position", "required"]),
        ({"cameras": [{"position": [0, 0, 0], "look_at": [0, 0, 0]}]}, ["cameras[0].look_at"]),
        ({"widht": 3}, ["widht", "unknown key"]),
        ({"objects": [{"type": "mesh", "file": "nowhere.obj"}]}, ["objects[0].file", "does not exist"]),
        ({"objects": [{"type": "mesh", "generator": "teapot"}]}, ["objects[0].generator", "'teapot'"]),
    ],
)
def test_bad_scenes_name_the_key_and_what_is_allowed(data, words, tmp_path):
    with pytest.raises(UsageError) as err:
        Scene.from_dict(data, base_dir=tmp_path, where="test.toml")
    message = str(err.value)
    assert message.startswith("test.toml: ")
    for w in words:
        assert w in message


def test_empty_and_non_finite_meshes_are_refused(tmp_path):
    (tmp_path / "empty.obj").write_text("v 0 0 0\n")
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(UsageError, match="no triangles"):
        Scene.from_dict({"objects": [{"type": "mesh", "file": "empty.obj"}]}, base_dir=tmp_path)
    with pytest.raises(UsageError, match="NaN or infinite"):
        Scene.from_dict({"objects": [{"type": "mesh", "file": "nan.obj"}]}, base_dir=tmp_path)


def test_malformed_toml_is_a_usage_error(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("width = = 3\n")
    with pytest.raises(UsageError, match="not valid TOML"):
        Scene.from_file(path)


def test_unknown_scene_name_lists_the_bundled_ones():
    with pytest.raises(UsageError, match="refract1"):
        Scene.load("no_such_scene")


def test_every_bundled_scene_loads_with_five_cameras():
    for name in bundled_scenes():
        scene = Scene.load(name)
        assert len(scene.cameras) == 5, name
        assert scene.objects, name
