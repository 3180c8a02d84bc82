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
        ({"lights": [{"type": "laser"}]}, ["lights[0].type", "'laser'", "'spot'"]),
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


# ------------------------------------------------------------ bounds checked before tomllib parses
def test_a_long_dotted_key_is_refused_before_parsing(tmp_path, capsys):
    """tomllib keeps every prefix of a dotted key: 60 KB of `a.a.a...` took 3.6 GB and 11 s.  No scene
    nests deeper than 8, so a key of more parts is refused before the parser runs (here: in < 16 MB)."""
    import tracemalloc

    from tests.clitools import run_cli

    path = tmp_path / "dots.toml"
    path.write_text("width = 8\n" + "a" + ".a" * 30_000 + " = 1\n")
    tracemalloc.start()
    try:
        with pytest.raises(UsageError, match="line 2: a dotted key of more than 8 parts; allowed: at most 8"):
            Scene.from_file(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16e6
    code, out, err = run_cli(capsys, "render", str(path), "-o", str(tmp_path / "x.png"))
    assert code == 2 and err.count("\n") == 1 and err.startswith("clrender: ") and "dotted key" in err, err
    assert out == "" and not (tmp_path / "x.png").exists()


def test_dotted_keys_up_to_the_nesting_limit_and_dots_in_strings_are_read(tmp_path):
    path = tmp_path / "ok.toml"
    path.write_text(
        '# a comment, a.b.c.d.e.f.g.h.i.j\nmaterials.glass . "diffuse" = [0.5, 0.5, 0.5]\n'
        'description = "v, 1.2.3.4.5.6.7.8.9.10"\n[[objects]]\ntype = "sphere"\ncenter = [0, 0, -3.5]\nradius = 1.5\n'
    )
    scene = Scene.from_file(path)
    assert scene.materials["glass"].diffuse == (0.5, 0.5, 0.5)
    assert scene.description == "v, 1.2.3.4.5.6.7.8.9.10"


def test_a_scene_file_over_16_mib_is_refused_before_it_is_read(tmp_path):
    from clrender.scene.toml_text import MAX_SCENE_BYTES

    path = tmp_path / "huge.toml"
    with open(path, "wb") as f:  # sparse: comments would read as well, but need writing
        f.truncate(MAX_SCENE_BYTES + 1)
    with pytest.raises(UsageError, match=r"larger than 16 MiB; allowed: at most 16777216 bytes"):
        Scene.from_file(path)
