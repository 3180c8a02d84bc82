"""pbrt-v4 scene files (clrender/scene/pbrt.py): each directive against hand-computed answers, bad input in
one line (exit 2), and a scene written in pbrt and in TOML rendering the same bits.

Coordinates: the reader mirrors pbrt's world in x into clrender's (pbrt.MIRROR), so a pbrt point (x, y, z)
is expected at (−x, y, z) below, and every expected triangle's winding is reversed from the file's (for a
transform without a reflection)."""

import math
import tomllib

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.scene.pbrt import read_pbrt, read_pbrt_file
from clrender.scene.scene import Scene

from tests.clitools import run_cli

TRIANGLE = 'Shape "trianglemesh" "point3 P" [1 0 0  0 1 0  0 0 1] "integer indices" [0 1 2]\n'


def write(tmp_path, text, name="scene.pbrt"):
    path = tmp_path / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def only_mesh(data):
    meshes = [o for o in data["objects"] if o["type"] == "mesh"]
    assert len(meshes) == 1
    return meshes[0]["vertices"], meshes[0]["faces"]


def test_transforms_compose_in_pbrts_order(tmp_path):
    # ctm = T(1,2,3) R(90 about z) S(2,1,1): (1,0,0) -> (2,0,0) -> (0,2,0) -> (1,4,3); mirrored (-1,4,3)
    data = read_pbrt(write(tmp_path, "WorldBegin\nTranslate 1 2 3\nRotate 90 0 0 1\nScale 2 1 1\n" + TRIANGLE))
    vertices, faces = only_mesh(data)
    # (0,1,0) -> (0,1,0) -> (-1,0,0) -> (0,2,3); (0,0,1) -> (0,0,1) -> (0,0,1) -> (1,2,4)
    np.testing.assert_allclose(vertices, [[-1, 4, 3], [0, 2, 3], [-1, 2, 4]], atol=1e-12)
    assert faces.tolist() == [[2, 1, 0]]  # the mirror reverses the winding; the reader reverses it back


def test_transform_is_column_major_and_concat_multiplies_on_the_right(tmp_path):
    text = "WorldBegin\nTransform [1 0 0 0  0 1 0 0  0 0 1 0  5 6 7 1]\nConcatTransform [2 0 0 0  0 2 0 0  0 0 2 0  0 0 0 1]\n" + TRIANGLE
    vertices, _ = only_mesh(read_pbrt(write(tmp_path, text)))
    np.testing.assert_allclose(vertices[0], [-(5 + 2), 6, 7])  # scale by 2 first, then translate (5, 6, 7)


def test_world_begin_resets_the_transform_and_coordinate_systems_are_named(tmp_path):
    text = 'Translate 9 9 9\nWorldBegin\nTranslate 0 5 0\nCoordinateSystem "up"\nTranslate 0 100 0\nCoordSysTransform "up"\n' + TRIANGLE
    vertices, _ = only_mesh(read_pbrt(write(tmp_path, text)))
    np.testing.assert_allclose(vertices[0], [-1, 5, 0])


def test_attributes_scope_transform_and_material_transform_blocks_only_the_transform(tmp_path):
    text = (
        'WorldBegin\nMakeNamedMaterial "red" "string type" "diffuse" "rgb reflectance" [1 0 0]\n'
        'AttributeBegin\nNamedMaterial "red"\nTranslate 0 1 0\n' + TRIANGLE + "AttributeEnd\n" + TRIANGLE
    )
    text += 'TransformBegin\nNamedMaterial "red"\nTranslate 0 7 0\nTransformEnd\n' + TRIANGLE
    data = read_pbrt(write(tmp_path, text))
    first, second, third = data["objects"]
    assert first["material"] == "red" and first["vertices"][0].tolist() == [-1, 1, 0]
    assert second["material"] == "default" and second["vertices"][0].tolist() == [-1, 0, 0]
    assert third["material"] == "red" and third["vertices"][0].tolist() == [-1, 0, 0]
    assert data["materials"]["red"] == {"diffuse": [1.0, 0.0, 0.0]}
    assert data["materials"]["default"] == {"diffuse": [0.5, 0.5, 0.5]}  # pbrt's default material


def test_instances_place_the_definition_by_the_instance_transform_and_share_it(tmp_path):
    text = 'WorldBegin\nObjectBegin "tri"\nTranslate 0 0 10\n' + TRIANGLE + 'ObjectEnd\nTranslate 0 3 0\nObjectInstance "tri"\n'
    text += 'Translate 0 3 0\nObjectInstance "tri"\nScale -1 1 1\nObjectInstance "tri"\n'
    path = write(tmp_path, text)
    objects = read_pbrt(path)["objects"]
    assert objects[0]["vertices"] is objects[1]["vertices"] and objects[0]["faces"] is objects[1]["faces"]  # one array, two matrices
    assert objects[2]["faces"].tolist() == [[0, 1, 2]]  # a mirroring instance keeps the file's winding (two mirrors)
    meshes = Scene.from_file(path).objects
    assert [m.vertices[0].tolist() for m in meshes] == [[-1, 3, 10], [-1, 6, 10], [1, 6, 10]]
    assert meshes[0].shape_key == meshes[1].shape_key != meshes[2].shape_key
    assert meshes[0].local_vertices is meshes[1].local_vertices  # clrender's instancing: one object-space mesh


def test_includes_are_relative_to_the_scene_and_imports_too(tmp_path):
    write(tmp_path, 'MakeNamedMaterial "m" "string type" "diffuse"\n', "parts/materials.pbrt")
    write(tmp_path, 'NamedMaterial "m"\n' + TRIANGLE, "parts/shapes.pbrt")
    data = read_pbrt(write(tmp_path, 'WorldBegin\nInclude "parts/materials.pbrt"\nImport "parts/shapes.pbrt"\n'))
    assert data["objects"][0]["material"] == "m"


def test_camera_is_not_mirrored_left_handed_world_right_in_the_image(tmp_path):
    """pbrt's default camera sits at the origin looking down +z with +y up, and in its left-handed camera space
    +x is to the right: with a 40 x 20 film and fov 90 (the vertical, shorter axis) a point (x, y, 1) falls on
    raster ((x + 2)/4 · 40, (1 − y)/2 · 20), so (1, 0.5, 1) is at pixel (30, 5): right of centre, near the top."""
    text = 'Camera "perspective" "float fov" 90\nFilm "rgb" "integer xresolution" 40 "integer yresolution" 20\nWorldBegin\n'
    text += 'LightSource "point" "rgb I" [1 1 1]\nTranslate 1 0.5 1\nShape "sphere" "float radius" 0.08\n'
    camera = read_pbrt(write(tmp_path, text))["cameras"][0]
    scene = Scene.from_file(tmp_path / "scene.pbrt")
    origins, directions = scene.cameras[0].rays(40, 20)
    directions = np.asarray(directions).reshape(20, 40, 3)
    centre = np.array(scene.objects[0].center)
    hit = np.linalg.norm(np.cross(directions, centre), axis=-1) / np.linalg.norm(directions, axis=-1) < 0.08
    rows, cols = np.nonzero(hit)
    assert abs(cols.mean() + 0.5 - 30) < 0.6 and abs(rows.mean() + 0.5 - 5) < 0.6
    assert camera["fov"] == 90


@pytest.mark.slow
def test_rendered_camera_is_not_mirrored(tmp_path):
    from clrender.trace.renderer import render

    text = 'Camera "perspective" "float fov" 90\nFilm "rgb" "integer xresolution" 40 "integer yresolution" 20\nWorldBegin\n'
    text += 'LightSource "point" "rgb I" [1 1 1]\nTranslate 1 0.5 1\nShape "sphere" "float radius" 0.08\n'
    image = render(Scene.from_file(write(tmp_path, text)))
    rows, cols = np.nonzero(image.sum(axis=2) > 0)
    assert len(rows) > 0
    assert abs(cols.mean() + 0.5 - 30) < 0.6 and abs(rows.mean() + 0.5 - 5) < 0.6


def test_fov_spans_the_shorter_side(tmp_path):
    text = 'Camera "perspective" "float fov" 60 "float lensradius" 0.1 "float focaldistance" 4\n'
    text += 'Film "rgb" "integer xresolution" 20 "integer yresolution" 40\nWorldBegin\n'
    data = read_pbrt(write(tmp_path, text))
    camera = data["cameras"][0]
    assert camera["fov"] == pytest.approx(math.degrees(2 * math.atan(math.tan(math.radians(30)) * 2)))
    assert (camera["aperture"], camera["focus_distance"], data["width"], data["height"]) == (0.1, 4.0, 20, 40)


def test_look_at_gives_clrenders_camera_in_the_mirrored_world(tmp_path):
    data = read_pbrt(write(tmp_path, 'LookAt 1 2 3  1 2 -7  0 1 0\nCamera "perspective"\nWorldBegin\n'))
    camera = data["cameras"][0]
    np.testing.assert_allclose(camera["position"], [-1, 2, 3], atol=1e-12)
    np.testing.assert_allclose(camera["look_at"], [-1, 2, 2], atol=1e-12)
    np.testing.assert_allclose(camera["up"], [0, 1, 0], atol=1e-12)


def test_settings_sampler_integrator_filter(tmp_path):
    text = 'Sampler "zsobol" "integer pixelsamples" 64\nIntegrator "volpath" "integer maxdepth" 5\nPixelFilter "triangle"\nWorldBegin\n'
    expected = {"spp": 64, "path_sampler": "sobol", "integrator": "path", "max_depth": 4, "rfilter": "tent"}
    assert read_pbrt_file(write(tmp_path, text)).settings == expected
    text = 'Sampler "stratified" "integer xsamples" 2 "integer ysamples" 3\nPixelFilter "gaussian"\nWorldBegin\n'
    assert read_pbrt_file(write(tmp_path, text)).settings == {"spp": 6, "path_sampler": "sobol", "rfilter": "gaussian"}


def test_materials_map_onto_the_contract(tmp_path):
    text = (
        "WorldBegin\n"
        'MakeNamedMaterial "gold" "string type" "conductor" "spectrum eta" "metal-Au-eta" "spectrum k" "metal-Au-k" "float roughness" 0.01\n'
        'MakeNamedMaterial "raw" "string type" "conductor" "float roughness" 0.09 "bool remaproughness" false\n'
        'MakeNamedMaterial "coat" "string type" "coateddiffuse" "rgb reflectance" [0.2 0.3 0.4] "float roughness" 0\n'
        'MakeNamedMaterial "pane" "string type" "thindielectric" "float eta" 1.33\n'
        'MakeNamedMaterial "glass" "string type" "dielectric" "spectrum eta" "glass-BK7"\n'
        'MakeNamedMaterial "frost" "string type" "dielectric" "float roughness" 0.0625\n'
        'MakeNamedMaterial "pick" "string type" "mix" "string materials" ["gold" "pane"] "float amount" 1\n'
    )
    m = read_pbrt(write(tmp_path, text))["materials"]
    gold = {"type": "conductor", "eta": [0.143, 0.3753, 1.442], "k": [3.983, 2.3856, 1.6034], "roughness": pytest.approx(0.1**0.5), "tint": [1.0] * 3}
    assert m["gold"] == gold  # alpha = sqrt(0.01) = 0.1 = r^2
    assert m["raw"]["roughness"] == pytest.approx(0.3)  # alpha = 0.09 = r^2
    assert m["raw"]["eta"] == [0.201, 0.9237, 1.1022]  # pbrt's default metal: copper
    assert m["coat"] == {"type": "coated_diffuse", "diffuse": [0.2, 0.3, 0.4], "ior": 1.5, "roughness": 0.0, "tint": [1.0] * 3, "nonlinear": False}
    assert m["pane"] == {"type": "thin_dielectric", "ior": 1.33, "tint": [1.0] * 3}
    assert m["glass"] == {"diffuse": [0.0] * 3, "transparency": 1.0, "ior": 1.5168}
    assert m["frost"]["roughness"] == pytest.approx(0.5) and m["frost"]["transmission"] == 1.0  # alpha = sqrt(0.0625) = 0.25
    assert m["pick"] == m["pane"]


def test_lights(tmp_path):
    text = (
        "WorldBegin\nTranslate 0 1 0\n"
        'LightSource "point" "rgb I" [1 2 3] "float scale" 2 "point3 from" [1 0 0]\n'
        'LightSource "spot" "point3 from" [0 0 0] "point3 to" [1 0 0] "float coneangle" 40 "float conedelta" 10 "rgb I" [5 5 5]\n'
        'LightSource "distant" "point3 from" [0 0 0] "point3 to" [1 -1 0] "rgb L" [3 3 3]\n'
        'LightSource "infinite" "rgb L" [0.1 0.2 0.3] "float scale" 2\n'
    )
    data = read_pbrt(write(tmp_path, text))
    point, spot, distant = data["lights"]
    assert point == {"type": "point", "position": [-1, 1, 0], "color": [1, 2, 3], "intensity": 2, "falloff": "inverse_square"}
    assert spot == {
        "type": "spot",
        "position": [0, 1, 0],
        "direction": [-1, 0, 0],
        "cutoff_angle": 40,
        "beam_width": 30,
        "profile": "pbrt",
        "color": [5, 5, 5],
        "intensity": 1,
    }
    np.testing.assert_allclose(distant["direction"], [-(0.5**0.5), -(0.5**0.5), 0])
    assert data["environment"] == {"color": pytest.approx([0.2, 0.4, 0.6])}


def test_area_light_is_emission_on_the_side_pbrt_emits(tmp_path):
    # pbrt's bilinear patch faces dp/du x dp/dv = (1,0,0) x (0,0,1) = (0,-1,0): down
    text = 'WorldBegin\nAreaLightSource "diffuse" "rgb L" [4 5 6] "float scale" 2\n'
    text += 'Shape "bilinearmesh" "point3 P" [0 0 0  1 0 0  0 0 1  1 0 1]\n'
    data = read_pbrt(write(tmp_path, text))
    mesh = data["objects"][0]
    assert data["materials"][mesh["material"]]["emission"] == [8, 10, 12]
    v = np.array(mesh["vertices"])
    for a, b, c in mesh["faces"]:
        normal = np.cross(v[b] - v[a], v[c] - v[a])
        assert normal[1] < 0 and abs(normal[0]) + abs(normal[2]) < 1e-12


def test_reverse_orientation_and_disks_face_by_pbrts_rule(tmp_path):
    text = 'WorldBegin\nShape "disk" "float radius" 1\nReverseOrientation\nShape "disk" "float radius" 1\n'
    objects = read_pbrt(write(tmp_path, text))["objects"]
    for obj, sign in zip(objects, (1, -1), strict=True):  # a disk faces +z in object space
        v, f = np.array(obj["vertices"]), np.array(obj["faces"])
        normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        assert np.all(np.sign(normals[:, 2]) == sign)
        assert len(f) == 64


def test_approximate_substitutes_and_lists(tmp_path):
    path = write(tmp_path, 'WorldBegin\nMaterial "hair"\n' + TRIANGLE)
    result = read_pbrt_file(path, approximate=True)
    assert len(result.substitutions) == 1 and 'Material "hair"' in result.substitutions[0] and "grey diffuse" in result.substitutions[0]
    assert result.scene["materials"][result.scene["objects"][0]["material"]] == {"diffuse": [0.5, 0.5, 0.5]}


@pytest.mark.parametrize(
    "text, message",
    [
        ("WorldBegin\nFrobnicate 1\n", "scene.pbrt:2: unknown directive 'Frobnicate'"),
        ('WorldBegin\nMaterial "hair"\n', 'scene.pbrt:2: Material "hair" is not supported (supported: diffuse, conductor,'),
        ('WorldBegin\nShape "curve"\n', 'scene.pbrt:2: Shape "curve" is not supported (supported: trianglemesh,'),
        ("WorldBegin\nTranslate 1 2x 3\n", "scene.pbrt:2: '2x' is not a number"),
        ('WorldBegin\nShape "plymesh" "string filename" "nothere.ply"\n', "'nothere.ply' does not exist"),
        ('WorldBegin\nShape "sphere" "float radius" "big\n', "scene.pbrt:2: unterminated string"),
        ('WorldBegin\nShape "trianglemesh" "point3 P" [0 0 0 1 0 0\nWorldBegin\n', 'scene.pbrt:2: parameter "point3 P": unterminated bracket'),
        ('WorldBegin\nShape "sphere" "float radius" [1\n', 'scene.pbrt:2: parameter "float radius": unterminated bracket'),
        ('WorldBegin\nMakeNamedMedium "fog" "string type" "homogeneous"\n', "MakeNamedMedium (participating media) is not supported"),
        ('WorldBegin\nShape "sphere" "float radius" 1 "float bogus" 2\n', 'parameter "bogus" is not supported'),
        ('WorldBegin\nNamedMaterial "nope"\n', 'NamedMaterial "nope" is not defined'),
        ("WorldBegin\nAttributeEnd\n", "AttributeEnd without a matching AttributeBegin"),
        ('WorldBegin\nInclude "scene.pbrt"\n', "includes itself"),
        ('WorldBegin\nObjectBegin "a"\nObjectEnd\nObjectBegin "b"\nObjectInstance "a"\n', "scene.pbrt:5: ObjectInstance inside ObjectBegin"),
        ('WorldBegin\nObjectInstance "a"\n', 'scene.pbrt:2: ObjectInstance "a" is not defined'),
        ('Scale 0 0 0\nCamera "perspective"\nWorldBegin\n', "scene.pbrt:2: Camera: its transform is singular"),
        ('Scale -1 1 1\nCamera "perspective"\nWorldBegin\n', "scene.pbrt:2: Camera: its transform mirrors the image"),
        ('WorldBegin\nShape "trianglemesh" "point3 P" [0 0 0  1 0 0  0 1 0  1 1 0]\n', 'scene.pbrt:2: without "integer indices"'),
        ('WorldBegin\nShape "trianglemesh" "point3 P" [0 0 0  1 0 0  0 1 0] "integer indices" [0 1 3]\n', '"indices": 3 values'),
        ('WorldBegin\nShape "disk" "float phimax" 0\n', 'scene.pbrt:2: Shape "disk": phimax 0'),
        ('Integrator "path" "integer maxdepth" 0\nWorldBegin\n', 'scene.pbrt:1: Integrator "maxdepth" 0'),
        ('WorldBegin\nLightSource "infinite" "string filename" "sky.exr"\n', '"filename" (an equal-area octahedral map) is not'),
        ('WorldBegin\nAreaLightSource "diffuse" "bool twosided" true\n', 'AreaLightSource "twosided" true is not supported'),
        ('WorldBegin\nMaterial "mix" "string materials" ["default" "default"] "float amount" 0.5\n', 'Material "mix" with amount 0.5 is not'),
    ],
)
def test_bad_input_is_one_line(tmp_path, text, message):
    with pytest.raises(UsageError) as info:
        read_pbrt(write(tmp_path, text))
    assert message in str(info.value) and "\n" not in str(info.value)


def test_include_escaping_the_folder_is_refused_when_confined(tmp_path):
    write(tmp_path, TRIANGLE, "outside.pbrt")
    path = write(tmp_path, 'WorldBegin\nInclude "../outside.pbrt"\n', "scene/scene.pbrt")
    with pytest.raises(UsageError, match="outside the scene folder"):
        read_pbrt(path, allow_outside=False)
    assert read_pbrt(path)["objects"]  # a local file may climb out


def test_cli_refuses_in_one_line_exit_2_nothing_written(tmp_path, capsys):
    path = write(tmp_path, 'WorldBegin\n\nMaterial "hair"\n' + TRIANGLE)
    out = tmp_path / "out.png"
    code, _, err = run_cli(capsys, "render", str(path), "-o", str(out))
    assert code == 2 and not out.exists()
    assert err.strip().count("\n") == 0 and 'scene.pbrt:3: Material "hair" is not supported' in err


CORNELL_PBRT = """# a Cornell-like box: a diffuse sphere, a red and a green wall, a square light
LookAt 0 1 3.4  0 1 0  0 1 0
Camera "perspective" "float fov" 45
Film "rgb" "integer xresolution" 32 "integer yresolution" 24
WorldBegin
MakeNamedMaterial "white" "string type" "diffuse" "rgb reflectance" [0.75 0.75 0.75]
MakeNamedMaterial "red" "string type" "diffuse" "rgb reflectance" [0.75 0.1 0.1]
MakeNamedMaterial "green" "string type" "diffuse" "rgb reflectance" [0.1 0.75 0.1]
NamedMaterial "white"
Shape "trianglemesh" "point3 P" [-1 0 -1  1 0 -1  1 0 1  -1 0 1] "integer indices" [0 2 1  0 3 2]
Shape "trianglemesh" "point3 P" [-1 2 -1  1 2 -1  1 2 1  -1 2 1] "integer indices" [0 1 2  0 2 3]
Shape "trianglemesh" "point3 P" [-1 0 -1  1 0 -1  1 2 -1  -1 2 -1] "integer indices" [0 1 2  0 2 3]
AttributeBegin
  NamedMaterial "red"
  Shape "trianglemesh" "point3 P" [-1 0 -1  -1 0 1  -1 2 1  -1 2 -1] "integer indices" [0 2 1  0 3 2]
AttributeEnd
AttributeBegin
  NamedMaterial "green"
  Shape "trianglemesh" "point3 P" [1 0 -1  1 0 1  1 2 1  1 2 -1] "integer indices" [0 1 2  0 2 3]
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [6 6 6]
  Translate 0 1.98 0
  Shape "bilinearmesh" "point3 P" [-0.3 0 -0.3  0.3 0 -0.3  -0.3 0 0.3  0.3 0 0.3]
AttributeEnd
AttributeBegin
  Translate 0.35 0.4 -0.2
  Shape "sphere" "float radius" 0.4
AttributeEnd
"""

# The same scene written by hand as clrender TOML: x negated (pbrt's world mirrored), each triangle's winding
# reversed (the file's winding after the mirror would face the other way), the light's patch as its two triangles.
CORNELL_TOML = """
width = 32
height = 24
[[cameras]]
position = [-0.0, 1.0, 3.4]
look_at = [-0.0, 1.0, 2.4]
up = [-0.0, 1.0, 0.0]
fov = 45.0
[materials.default]
diffuse = [0.5, 0.5, 0.5]
[materials.white]
diffuse = [0.75, 0.75, 0.75]
[materials.red]
diffuse = [0.75, 0.1, 0.1]
[materials.green]
diffuse = [0.1, 0.75, 0.1]
[materials.light]
diffuse = [0.75, 0.75, 0.75]
emission = [6.0, 6.0, 6.0]
[[objects]]
type = "mesh"
vertices = [[1, 0, -1], [-1, 0, -1], [-1, 0, 1], [1, 0, 1]]
faces = [[1, 2, 0], [2, 3, 0]]
material = "white"
[[objects]]
type = "mesh"
vertices = [[1, 2, -1], [-1, 2, -1], [-1, 2, 1], [1, 2, 1]]
faces = [[2, 1, 0], [3, 2, 0]]
material = "white"
[[objects]]
type = "mesh"
vertices = [[1, 0, -1], [-1, 0, -1], [-1, 2, -1], [1, 2, -1]]
faces = [[2, 1, 0], [3, 2, 0]]
material = "white"
[[objects]]
type = "mesh"
vertices = [[1, 0, -1], [1, 0, 1], [1, 2, 1], [1, 2, -1]]
faces = [[1, 2, 0], [2, 3, 0]]
material = "red"
[[objects]]
type = "mesh"
vertices = [[-1, 0, -1], [-1, 0, 1], [-1, 2, 1], [-1, 2, -1]]
faces = [[2, 1, 0], [3, 2, 0]]
material = "green"
[[objects]]
type = "mesh"
vertices = [[0.3, 1.98, -0.3], [-0.3, 1.98, -0.3], [0.3, 1.98, 0.3], [-0.3, 1.98, 0.3]]
faces = [[3, 1, 0], [2, 3, 0]]
material = "light"
[[objects]]
type = "sphere"
center = [-0.35, 0.4, -0.2]
radius = 0.4
material = "white"
"""


def cornell(tmp_path):
    pbrt = Scene.from_file(write(tmp_path, CORNELL_PBRT))
    toml = Scene.from_dict(tomllib.loads(CORNELL_TOML), base_dir=tmp_path)
    return pbrt, toml


def test_cornell_box_reads_as_its_toml(tmp_path):
    pbrt, toml = cornell(tmp_path)
    assert pbrt.cameras == toml.cameras and (pbrt.width, pbrt.height) == (toml.width, toml.height)
    assert len(pbrt.objects) == len(toml.objects)
    for a, b in zip(pbrt.objects, toml.objects, strict=True):
        if hasattr(a, "faces"):
            assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
            assert pbrt.materials[a.material] == toml.materials[b.material]
        else:
            assert (a.center, a.radius, pbrt.materials[a.material]) == (b.center, b.radius, toml.materials[b.material])


@pytest.mark.slow
def test_cornell_box_renders_the_same_bits_as_its_toml(tmp_path):
    from clrender.trace.renderer import render

    pbrt, toml = cornell(tmp_path)
    a = render(pbrt, integrator="path", spp=4, seed=3)
    b = render(toml, integrator="path", spp=4, seed=3)
    assert a.mean() > 0.01  # the light reaches the box
    assert np.array_equal(a, b)


def test_image_texture_and_uv_reach_the_mesh(tmp_path):
    from PIL import Image

    Image.new("RGB", (2, 2), (255, 0, 0)).save(tmp_path / "red.png")
    text = 'WorldBegin\nTexture "t" "spectrum" "imagemap" "string filename" "red.png" "string wrap" "clamp"\n'
    text += 'Material "diffuse" "texture reflectance" "t"\n'
    text += 'Shape "trianglemesh" "point3 P" [1 0 0  0 1 0  0 0 1] "integer indices" [0 1 2] "point2 uv" [0 0  1 0  0.25 1]\n'
    path = write(tmp_path, text)
    data = read_pbrt(path)
    assert data["textures"] == {"t": {"file": "red.png", "wrap_s": "clamp_to_edge", "wrap_t": "clamp_to_edge", "filter": "linear"}}
    assert data["materials"][data["objects"][0]["material"]] == {"diffuse": [1.0, 1.0, 1.0], "diffuse_texture": "t"}
    mesh = Scene.from_file(path).objects[0]
    np.testing.assert_array_equal(mesh.uvs, [[0, 1], [1, 1], [0.25, 0]])  # pbrt's (u, v) is glTF's (u, 1 - v)


def test_plymesh_is_read_relative_to_the_scene_and_mirrored(tmp_path):
    import trimesh

    (tmp_path / "meshes").mkdir()
    trimesh.Trimesh([[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2]], process=False).export(tmp_path / "meshes" / "tri.ply")
    data = read_pbrt(write(tmp_path, 'WorldBegin\nTranslate 0 0 5\nShape "plymesh" "string filename" "meshes/tri.ply"\n'))
    vertices, faces = only_mesh(data)
    np.testing.assert_array_equal(vertices, [[-1, 0, 5], [0, 1, 5], [0, 0, 6]])
    assert faces.tolist() == [[2, 1, 0]]


def test_a_big_mesh_is_read_as_arrays_past_the_dicts_value_count(tmp_path):
    """320,000 triangles over 40,401 points: 1.08 M numbers, more than the 1 M values a TOML scene may hold
    (checks.MAX_VALUES), read in well under a second."""
    n = 200
    u, v = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
    points = np.stack([u.ravel(), v.ravel(), np.zeros(u.size)], 1) / n
    quads = (np.arange(n)[None, :] + (n + 1) * np.arange(n)[:, None]).ravel()
    faces = np.concatenate([np.stack([quads, quads + 1, quads + n + 2], 1), np.stack([quads, quads + n + 2, quads + n + 1], 1)])
    faces = np.tile(faces, (4, 1))
    text = 'WorldBegin\nShape "trianglemesh" "point3 P" [' + " ".join(map(repr, points.ravel().tolist())) + '] "integer indices" ['
    text += " ".join(map(str, faces.ravel().tolist())) + "]\n"
    scene = Scene.from_file(write(tmp_path, text))
    assert len(scene.objects[0].faces) == len(faces)
    np.testing.assert_array_equal(scene.objects[0].vertices[:, 0], -points[:, 0])


@pytest.mark.parametrize(
    "change, message",
    [
        ({"vertices": np.array([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]])}, "not finite or out of range"),
        ({"faces": np.array([[0, 1, 3]])}, "a vertex index is out of range"),
        ({"faces": np.array([[0.0, 1.0, 2.0]])}, "expected an integer array"),
        ({"uvs": np.zeros((2, 2))}, "expected an array of 3 finite [u, v] pairs"),
    ],
)
def test_array_meshes_are_checked(change, message):
    mesh = {"type": "mesh", "vertices": np.eye(3), "faces": np.array([[0, 1, 2]]), **change}
    with pytest.raises(UsageError) as info:
        Scene.from_dict({"objects": [mesh]})
    assert message in str(info.value)


def test_array_and_list_meshes_are_the_same_mesh():
    lists = {"type": "mesh", "vertices": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "faces": [[0, 1, 2]], "uvs": [[0, 0], [1, 0], [0, 1]]}
    arrays = {key: np.array(value) if isinstance(value, list) else value for key, value in lists.items()}
    a, b = (Scene.from_dict({"objects": [m]}).objects[0] for m in (lists, arrays))
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces) and np.array_equal(a.uvs, b.uvs)


def test_a_missing_scene_file_is_one_line(tmp_path, capsys):
    code, _, err = run_cli(capsys, "render", str(tmp_path / "nothere.pbrt"), "-o", str(tmp_path / "x.png"))
    assert code == 2 and "nothere.pbrt" in err and "does not exist" in err and err.strip().count("\n") == 0


@pytest.mark.parametrize(
    "matrix, message",
    [
        ([[1, 0, 0], [0, 1, 0], [0, 0, 1]], "expected 4 rows of 4 finite numbers"),
        ([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]], "its last row must be [0, 0, 0, 1]"),
        ([[0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "invertible"),
        ([[float("nan"), 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "finite"),
    ],
)
def test_mesh_matrix_is_checked(matrix, message):
    mesh = {"type": "mesh", "vertices": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "faces": [[0, 1, 2]], "matrix": matrix}
    with pytest.raises(UsageError) as info:
        Scene.from_dict({"objects": [mesh]})
    assert message in str(info.value)


def test_mesh_matrix_places_the_mesh():
    matrix = [[0, -2, 0, 1], [2, 0, 0, 2], [0, 0, 2, 3], [0, 0, 0, 1]]  # a quarter turn about z, doubled, then moved
    mesh = {"type": "mesh", "vertices": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "faces": [[0, 1, 2]], "matrix": matrix}
    placed = Scene.from_dict({"objects": [mesh]}).objects[0].vertices
    np.testing.assert_array_equal(placed, [[1, 4, 3], [-1, 2, 3], [1, 2, 5]])


def test_render_list_shows_the_one_camera(tmp_path, capsys):
    code, out, _ = run_cli(capsys, "render", str(write(tmp_path, "WorldBegin\n" + TRIANGLE)), "--list")
    assert code == 0 and "* --camera 1" in out


def test_shapes_under_one_area_light_share_one_emitting_material(tmp_path):
    text = 'WorldBegin\nAreaLightSource "diffuse" "rgb L" [1 1 1]\n' + TRIANGLE * 3
    data = read_pbrt(write(tmp_path, text))
    assert len({o["material"] for o in data["objects"]}) == 1 and len(data["materials"]) == 2


def test_an_emitting_sphere_is_a_mesh_of_the_spheres_area_facing_out(tmp_path):
    """The path tracer light-samples emissive triangles, not analytic spheres: an area-lit sphere becomes a closed
    mesh of area 4 pi r^2 (so it keeps its power), every face turned away from the centre; a plain one stays a sphere."""
    lamp = 'AttributeBegin\nAreaLightSource "diffuse" "rgb L" [5 5 5]\nShape "sphere" "float radius" 0.5\nAttributeEnd\n'
    text = "WorldBegin\nTranslate 1 2 3\n" + lamp + 'Shape "sphere"\n'
    lit, plain = read_pbrt(write(tmp_path, text))["objects"]
    assert plain["type"] == "sphere"
    points, faces = np.asarray(lit["vertices"], np.float64), np.asarray(lit["faces"])
    a, b, c = (points[faces[:, i]] for i in range(3))
    normals = np.cross(b - a, c - a)
    assert 0.5 * np.linalg.norm(normals, axis=1).sum() == pytest.approx(4 * math.pi * 0.25, rel=1e-9)
    centre = points.mean(axis=0)
    assert np.all(np.einsum("ij,ij->i", (a + b + c) / 3 - centre, normals) > 0)
