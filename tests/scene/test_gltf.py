"""glTF 2.0 scenes: node transforms, cameras, KHR_lights_punctual lights and base colours.

Files are written here, by trimesh's exporter or as hand-written JSON (tests/gltftools.py), and
every expected value comes from the numbers put into the file: transforms
applied in numpy, the camera's axes from its quaternion, Lambert's law for
the glTF BRDF base_colour / pi.
"""

import json
import math

import numpy as np
import pytest
import trimesh

from clrender.scene.gltf import node_mesh, scene_dict
from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from tests.clitools import run_cli
from tests.gltftools import gltf_file, quaternion


def rotation(axis, degrees):
    return trimesh.transformations.rotation_matrix(math.radians(degrees), axis)[:3, :3]


# ------------------------------------------------------------- transforms
@pytest.fixture
def box_glb(tmp_path):
    """A unit box under a parent node, exported by trimesh: world = parent @ child."""
    parent = trimesh.transformations.compose_matrix(angles=[0.3, -0.7, 0.2], translate=[1.0, -2.0, -6.0])
    child = trimesh.transformations.compose_matrix(scale=[2.0, 0.5, 1.5], translate=[0.5, 0.0, 0.0])
    scene = trimesh.Scene()
    scene.graph.update(frame_to="parent", frame_from=scene.graph.base_frame, matrix=parent)
    box = trimesh.creation.box()
    box.visual = trimesh.visual.TextureVisuals(material=trimesh.visual.material.PBRMaterial(baseColorFactor=[51, 102, 204, 255]))
    scene.add_geometry(box, node_name="box", parent_node_name="parent", transform=child)
    path = tmp_path / "box.glb"
    path.write_bytes(scene.export(file_type="glb"))
    return path, box, parent @ child


def test_node_transforms_place_the_geometry(box_glb):
    path, box, world = box_glb
    scene = Scene.load(path)
    tracer = Tracer(scene)
    # a ray onto the centre of every face of the transformed box, from 3 units outside along its normal
    corners = box.vertices[box.faces]
    centres = trimesh.transform_points(corners.mean(axis=1), world)
    normals = box.face_normals @ np.linalg.inv(world[:3, :3])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    t, prim, obj = tracer.intersect(centres + 3 * normals, -normals)
    np.testing.assert_allclose(t, 3.0, atol=2e-5)
    assert (obj == 0).all()


def test_a_mesh_object_can_name_a_gltf_node(box_glb, tmp_path):
    path, box, world = box_glb
    d = scene_dict(path)
    (box_object,) = d["objects"]
    mesh = node_mesh(path, box_object["node"])
    np.testing.assert_allclose(mesh.vertices, trimesh.transform_points(box.vertices, world), atol=1e-5)
    # in a TOML scene: the node's world transform first, then the object's own translate
    (tmp_path / "s.toml").write_text(f'[[objects]]\ntype = "mesh"\nfile = "box.glb"\nnode = {box_object["node"]}\ntranslate = [0, 10, 0]\n')
    placed = Scene.load(tmp_path / "s.toml").objects[0]
    np.testing.assert_allclose(placed.vertices, mesh.vertices + [0, 10, 0], atol=1e-5)


def test_a_whole_gltf_file_as_one_mesh_keeps_its_node_transforms(box_glb, tmp_path):
    path, box, world = box_glb
    (tmp_path / "s.toml").write_text('[[objects]]\ntype = "mesh"\nfile = "box.glb"\n')
    (mesh,) = Scene.load(tmp_path / "s.toml").objects
    expected = trimesh.transform_points(box.vertices, world)
    np.testing.assert_allclose(np.sort(mesh.vertices, axis=0), np.sort(expected, axis=0), atol=1e-5)


def test_base_colour_becomes_the_diffuse_colour(box_glb):
    """The Whitted integrator draws a glTF material's base colour as its diffuse colour; the path tracer gets the
    metallic-roughness model as the file gives it (factors default to 1, as the specification says)."""
    path, _, _ = box_glb
    scene = Scene.load(path)
    (material,) = [scene.materials[o.material] for o in scene.objects]
    np.testing.assert_allclose(material.kd, [0.2, 0.4, 0.8], atol=1e-6)
    assert (material.model, material.metallic, material.roughness, material.emission) == ("gltf", 1.0, 1.0, (0.0, 0.0, 0.0))


# ------------------------------------------------------- cameras and lights
def test_vertex_normals_turn_with_the_inverse_transpose(tmp_path):
    """Under a stretch along x a normal tilts away from x: n M^-1, not M n."""
    path = gltf_file(tmp_path, [{"mesh": 0, "scale": [2, 1, 1]}], normals=[1 / math.sqrt(2), 0, 1 / math.sqrt(2)])
    (mesh,) = Scene.load(path).objects
    assert mesh.smooth
    expected = np.array([0.5, 0, 1]) / np.linalg.norm([0.5, 0, 1])
    np.testing.assert_allclose(mesh.vertex_normals, np.broadcast_to(expected, (4, 3)), atol=1e-6)


def test_smooth_without_normals_in_the_file_averages_the_faces(tmp_path):
    gltf_file(tmp_path, [{"mesh": 0, "rotation": quaternion([0, 1, 0], 90)}], name="quad.gltf")  # turned to face +x
    (tmp_path / "s.toml").write_text('[[objects]]\ntype = "mesh"\nfile = "quad.gltf"\nnode = 0\nsmooth = true\n')
    (mesh,) = Scene.load(tmp_path / "s.toml").objects
    np.testing.assert_allclose(mesh.vertex_normals, np.broadcast_to([1, 0, 0], (4, 3)), atol=1e-12)


def test_camera_position_direction_and_field_of_view(tmp_path):
    q = quaternion([0, 1, 0], 30)
    nodes = [
        {"mesh": 0, "translation": [0, 0, -5]},
        {"children": [2], "translation": [0, 1, 0]},  # a rig lifting the camera by 1
        {"camera": 0, "translation": [1, 1, 10], "rotation": q},
    ]
    path = gltf_file(tmp_path, nodes, cameras=[{"type": "perspective", "perspective": {"yfov": 0.6, "aspectRatio": 2.0, "znear": 0.1}}])
    scene = Scene.load(path)
    (cam,) = scene.cameras
    np.testing.assert_allclose(cam.position, [1, 2, 10])
    forward = np.subtract(cam.look_at, cam.position)
    np.testing.assert_allclose(forward / np.linalg.norm(forward), [-math.sin(math.radians(30)), 0, -math.cos(math.radians(30))], atol=1e-12)
    np.testing.assert_allclose(cam.up, [0, 1, 0], atol=1e-12)
    assert cam.fov == pytest.approx(math.degrees(0.6))
    assert (scene.width, scene.height) == (640, 320)  # the camera's aspect ratio


def test_punctual_lights_are_placed_by_their_nodes(tmp_path):
    nodes = [
        {"mesh": 0},
        {"translation": [3, 4, 5], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"rotation": quaternion([1, 0, 0], -90), "extensions": {"KHR_lights_punctual": {"light": 1}}},
        {"translation": [0, 7, 0], "extensions": {"KHR_lights_punctual": {"light": 2}}},
    ]
    lights = [
        {"type": "point", "color": [1, 0.5, 0.25], "intensity": 20},
        {"type": "directional", "intensity": 3},
        {"type": "spot", "intensity": 5, "spot": {"outerConeAngle": 0.5}},
    ]
    scene = Scene.load(gltf_file(tmp_path, nodes, lights=lights))
    point, sun, spot = scene.lights
    assert point.type == "point" and point.falloff == "inverse_square"
    np.testing.assert_allclose(point.position, [3, 4, 5])
    np.testing.assert_allclose(point.color, [1, 0.5, 0.25])
    assert point.intensity == pytest.approx(20)  # candela: the physical model's BRDF has the 1/pi
    assert sun.type == "directional" and sun.intensity == pytest.approx(3 / math.pi)
    np.testing.assert_allclose(np.asarray(sun.direction) / np.linalg.norm(sun.direction), [0, -1, 0], atol=1e-12)  # -z turned down
    assert spot.type == "point" and spot.position == (0, 7, 0)  # drawn as a point light at the spot's place


def test_a_flat_lit_quad_shows_lambert_for_the_gltf_brdf(tmp_path):
    """Radiance of a Lambertian surface (BRDF base_colour / pi) under E lux arriving at 60 degrees: base_colour / pi * E * cos 60."""
    base = [0.8, 0.5, 0.2]
    lux = 2.0
    nodes = [
        {"mesh": 0, "scale": [4, 4, 1], "translation": [0, 0, -3]},  # an 8 x 8 quad facing the camera
        {"camera": 0, "translation": [0, 0, 0]},
        {"rotation": quaternion([1, 0, 0], -60), "extensions": {"KHR_lights_punctual": {"light": 0}}},
    ]
    path = gltf_file(
        tmp_path,
        nodes,
        materials=[{"pbrMetallicRoughness": {"baseColorFactor": [*base, 1.0], "metallicFactor": 0}}],
        cameras=[{"type": "perspective", "perspective": {"yfov": 0.5}}],
        lights=[{"type": "directional", "intensity": lux}],
    )
    image = Renderer(path, width=8, height=6).run().image
    expected = np.array(base) / math.pi * lux * math.cos(math.radians(60))
    np.testing.assert_allclose(image, np.broadcast_to(expected, image.shape), rtol=1e-5)


def test_a_file_without_camera_or_lights_is_framed_and_lit_by_the_framing_rig(box_glb):
    path, _, world = box_glb
    d = scene_dict(path)
    (cam,) = d["cameras"]
    (light,) = d["lights"]
    assert light["type"] == "directional"
    toward = -np.asarray(light["direction"])
    view = np.subtract(cam["position"], cam["look_at"])
    right = np.cross(cam["up"], view)
    assert toward @ view > 0 and toward @ np.asarray(cam["up"]) > 0 and toward @ right < 0  # over the camera's left shoulder
    assert d["ambient"] == d["environment"]["color"] == [0.25] * 3  # and the fill (tests/scene/test_framing.py renders it)
    image = Renderer(path, width=16, height=12).run()
    assert (image.ids == 0).any() and (image.ids == -1).any()  # the box is in view, with room around it


def test_strips_and_fans_become_triangles(tmp_path):
    nodes = [{"mesh": 0}]
    fan = node_mesh(gltf_file(tmp_path, nodes, mode=6, indices=(0, 1, 2, 3), name="fan.gltf"), 0)
    strip = node_mesh(gltf_file(tmp_path, nodes, mode=5, indices=(0, 1, 3, 2), name="strip.gltf"), 0)
    np.testing.assert_array_equal(fan.faces, [[0, 1, 2], [0, 2, 3]])
    # the specification's strip rule: triangle i is (v_i, v_{i + 1 + i % 2}, v_{i + 2 - i % 2})
    np.testing.assert_array_equal(strip.faces, [[0, 1, 3], [1, 2, 3]])
    for mesh in (fan, strip):  # both cover the quad with the same orientation
        np.testing.assert_allclose(mesh.face_normals, [[0, 0, 1], [0, 0, 1]], atol=1e-12)


# ------------------------------------------------------------- bad files


def _edit(doc, key, value):
    doc = json.loads(json.dumps(doc))
    target = doc
    *path, last = key
    for k in path:
        target = target[k]
    target[last] = value
    return doc


@pytest.mark.parametrize(
    "damage, fragment",
    [
        (lambda p: p.write_bytes(b"glTF\x02\x00\x00\x00\xff\xff\x00\x00"), "GLB"),
        (lambda p: p.write_text("{not json"), "not a glTF file"),
        (lambda p: p.write_text(json.dumps(_edit(json.loads(p.read_text()), ["asset", "version"], "1.0"))), "version"),
        (lambda p: p.write_text(json.dumps(_edit(json.loads(p.read_text()), ["accessors", 0, "count"], 400))), "do not fit"),
        (
            lambda p: p.write_text(json.dumps(_edit(json.loads(p.read_text()), ["extensionsRequired"], ["KHR_draco_mesh_compression"]))),
            "KHR_draco_mesh_compression",
        ),
        (lambda p: p.write_text(json.dumps(_edit(json.loads(p.read_text()), ["nodes", 0, "mesh"], 7))), "meshes[7]"),
        (lambda p: p.write_text(json.dumps(_edit(json.loads(p.read_text()), ["nodes", 0, "children"], [0]))), "twice"),
        (lambda p: p.write_text(json.dumps(_edit(json.loads(p.read_text()), ["meshes", 0, "primitives"], "x"))), "primitives"),
    ],
)
def test_a_bad_gltf_is_refused_with_one_line(tmp_path, capsys, monkeypatch, damage, fragment):
    path = gltf_file(tmp_path, [{"mesh": 0}], name="bad.gltf")
    damage(path)
    if fragment == "GLB":
        path = path.rename(tmp_path / "bad.glb")
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, "render", str(path), "--width", "8", "--height", "6", "-o", "x.png")
    assert code == 2, err
    assert err.startswith("clrender: ") and err.count("\n") == 1 and fragment in err, err
    assert not (tmp_path / "x.png").exists()


def test_render_a_glb_from_the_command_line(box_glb, tmp_path, capsys):
    path, _, _ = box_glb
    out = tmp_path / "box.png"
    code, stdout, err = run_cli(capsys, "render", str(path), "--width", "16", "--height", "12", "-o", str(out))
    assert code == 0, err
    assert stdout.split() == [str(out)]


# ------------------------------------------------------------- doubleSided
@pytest.mark.parametrize("given, sided", [({}, False), ({"doubleSided": False}, False), ({"doubleSided": True}, True)])
def test_double_sided_is_read_with_the_specifications_default(tmp_path, given, sided):
    """glTF's doubleSided defaults to false: single-sided (camera rays cull its back faces, tests/trace/test_double_sided.py)."""
    path = gltf_file(tmp_path, [{"mesh": 0}], materials=[{"pbrMetallicRoughness": {}, **given}])
    (material,) = [Scene.load(path).materials[o.material] for o in Scene.load(path).objects]
    assert material.double_sided is sided


def test_a_double_sided_that_is_not_a_boolean_is_one_line_exit_2(tmp_path, capsys):
    path = gltf_file(tmp_path, [{"mesh": 0}], materials=[{"doubleSided": 1}])
    code, _, err = run_cli(capsys, "render", str(path), "-o", str(tmp_path / "out.png"))
    assert code == 2 and "doubleSided 1; allowed: true, false" in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out.png").exists()
